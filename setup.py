"""Build of the optional compiled kernels (everything else is configured in pyproject.toml).

The kernels are speed-ups only: each has a pure-Python reference in the same package that runs
when the extension is missing (``optional=True``: no C compiler, e.g. a Windows machine
without build tools, still installs parolkit) or when ``PAROLKIT_PURE_PYTHON=1`` is set.
"""

import sys

import numpy
from setuptools import Extension, setup

# Same floating-point order as the Python reference: no fused multiply-add contraction.
_ARGS = [] if sys.platform == "win32" else ["-O2", "-ffp-contract=off", "-fno-math-errno"]
# The sample fill is a plain loop over arrays: let the compiler vectorise it (no
# reassociation, so the results are the same as without).
_VECTORISE = [] if sys.platform == "win32" else ["-O3"]

setup(
    ext_modules=[
        Extension("parolkit.kinematics._cik", ["src/parolkit/kinematics/_cik.c"],
                  extra_compile_args=_ARGS, optional=True),
        Extension("parolkit.board._cgoto", ["src/parolkit/board/_cgoto.c"],
                  extra_compile_args=_ARGS, optional=True),
        Extension("parolkit.collision._ccollide", ["src/parolkit/collision/_ccollide.c"],
                  extra_compile_args=_ARGS, optional=True),
        Extension("parolkit.motion._csamples", ["src/parolkit/motion/_csamples.c"],
                  include_dirs=[numpy.get_include()],
                  extra_compile_args=_ARGS + _VECTORISE, optional=True),
    ],
)
