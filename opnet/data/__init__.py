"""Shape data: smooth toy shapes for tutorials and tests (:mod:`opnet.data.toy`)."""
from . import toy

__all__ = ["toy"]
