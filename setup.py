# The Python tools under python/ccir_mapping (catkin_python_setup puts them on the workspace's
# path, beside the generated messages); not for pip.
from setuptools import setup

from catkin_pkg.python_setup import generate_distutils_setup

setup(**generate_distutils_setup(packages=["ccir_mapping"], package_dir={"": "python"}))
