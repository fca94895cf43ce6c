"""legplan: motion planning for legged robots, as a pipeline of HDF5-exchanging stages."""

from legplan import _lazy_numpy_clone

__version__ = "0.1.0"

_lazy_numpy_clone.install()  # scipy.sparse without numpy.f2py / numpy.testing / numpy.ma (start-up time)
