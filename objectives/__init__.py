"""The domain side of tuner: filters, plants, controllers, data, metrics and the objectives built from them."""

# Before any kernel is defined: the package's numba cache locators (rule 3 of objectives.jit).
import objectives.jit  # noqa: E402,F401
