"""The domain side of tuner: filters, plants, controllers, data, metrics and the objectives built from them."""
