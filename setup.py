"""The C core's binding is built by cffi (src/hydrohil/core/build.py); everything else is in pyproject.toml."""
from setuptools import setup

setup(cffi_modules=["src/hydrohil/core/build.py:ffibuilder"])
