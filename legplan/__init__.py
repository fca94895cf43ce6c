"""legplan: motion planning for legged robots, as a pipeline of HDF5-exchanging stages."""

__version__ = "0.1.0"
