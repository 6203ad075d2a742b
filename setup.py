# SPDX-License-Identifier: Apache-2.0
"""pip install --no-build-isolation .  -> the `terracl` Python package (docs/python.md).

Drives CMake (the top CMakeLists.txt with only the Python module enabled) and puts the built
extension beside python/terracl/*.py. Needs Debian's python3-setuptools, pybind11-dev and the
build dependencies of scripts/install-deps.sh; no PyPI access (hence --no-build-isolation).
Environment: TERRACL_CMAKE_ARGS (extra cmake arguments), TERRACL_BUILD_JOBS (default 2),
TERRACL_BUILD_DIR (a build folder that already holds the module, python/terracl/_terracl*.so:
the wheel takes it as it is and compiles nothing). MPI/hypre are left out unless
TERRACL_CMAKE_ARGS asks for them (-DTERRACL_MPI=ON).
"""
import os
import shlex
import subprocess
import sys

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = os.path.dirname(os.path.abspath(__file__))


def version():
    with open(os.path.join(ROOT, "CMakeLists.txt")) as f:
        for line in f:
            if line.startswith("project(terracl VERSION"):
                return line.split("VERSION")[1].split()[0]
    return "0.0.0"


class CMakeExtension(Extension):
    def __init__(self, name):
        super().__init__(name, sources=[])


class CMakeBuild(build_ext):
    def build_extension(self, ext):
        out_dir = os.path.dirname(os.path.abspath(self.get_ext_fullpath(ext.name)))
        prebuilt = os.environ.get("TERRACL_BUILD_DIR")
        if prebuilt:
            built = os.path.join(os.path.abspath(prebuilt), "python", "terracl")
            modules = [n for n in (os.listdir(built) if os.path.isdir(built) else [])
                       if n.startswith("_terracl") and n.endswith(".so")]
            if not modules:
                sys.exit("TERRACL_BUILD_DIR=%s: no python/terracl/_terracl*.so there; build the target "
                         "terracl_python first (cmake --build %s --target terracl_python)" % (prebuilt, prebuilt))
            os.makedirs(out_dir, exist_ok=True)
            for name in modules:
                self.copy_file(os.path.join(built, name), os.path.join(out_dir, name))
            return
        build_dir = os.path.abspath(os.path.join(self.build_temp, "cmake"))
        os.makedirs(build_dir, exist_ok=True)
        args = [
            "-DCMAKE_BUILD_TYPE=Release",
            "-DPython3_EXECUTABLE=" + sys.executable,
            "-DTERRACL_BUILD_PYTHON=ON",
            "-DTERRACL_BUILD_TESTS=OFF",
            "-DTERRACL_BUILD_APPS=OFF",
            "-DTERRACL_BUILD_BENCHMARKS=OFF",
            "-DTERRACL_MPI=OFF",
        ] + shlex.split(os.environ.get("TERRACL_CMAKE_ARGS", ""))
        subprocess.check_call(["cmake", "-S", ROOT, "-B", build_dir] + args)
        subprocess.check_call(["cmake", "--build", build_dir, "--target", "terracl_python",
                               "-j", os.environ.get("TERRACL_BUILD_JOBS", "2")])
        built = os.path.join(build_dir, "python", "terracl")
        os.makedirs(out_dir, exist_ok=True)
        for name in os.listdir(built):
            if name.startswith("_terracl") and name.endswith(".so"):
                self.copy_file(os.path.join(built, name), os.path.join(out_dir, name))


setup(
    name="terracl",
    version=version(),
    description="Terrain authoring in the gradient domain on OpenCL devices (Python bindings)",
    license="Apache-2.0",
    classifiers=["License :: OSI Approved :: Apache Software License"],
    packages=["terracl"],
    package_dir={"": "python"},
    package_data={"terracl": ["__init__.pyi", "py.typed"]},
    ext_modules=[CMakeExtension("terracl._terracl")],
    cmdclass={"build_ext": CMakeBuild},
    python_requires=">=3.9",
    install_requires=["numpy"],
    extras_require={"geo": ["rasterio", "xarray"]},  # Heightfield.from_rasterio, to_xarray, .transform/.crs types
    zip_safe=False,
)
