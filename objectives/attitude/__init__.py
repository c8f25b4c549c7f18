"""Attitude estimation: quaternion kernels, recordings, filters, metrics and the filter objective."""
