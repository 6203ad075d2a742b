# SPDX-License-Identifier: Apache-2.0
# Debian packages with CPack (docs/cpp.md): `cd build && cpack -G DEB` makes one package per
# install component of cmake/TerraclInstall.cmake:
#   terracl          runtime: /usr/bin/terracl and libterracl.so.0 (Depends from dpkg-shlibdeps)
#   terracl-dev      headers, libterracl.a, the libterracl.so link, the CMake package
#   python3-terracl  the Python module, when python/ installs into the `python` component
set(CPACK_PACKAGE_NAME terracl)
set(CPACK_PACKAGE_VENDOR "terracl")
set(CPACK_PACKAGE_CONTACT "${TERRACL_PACKAGE_MAINTAINER}")  # cmake/TerraclInstall.cmake
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "Terrain authoring in the gradient domain on OpenCL devices")
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
# Debian policy (lintian): stripped binaries, an ldconfig trigger for the shared library.
set(CPACK_STRIP_FILES ON)
file(WRITE ${CMAKE_BINARY_DIR}/debian-control/triggers "activate-noawait ldconfig\n")
set(CPACK_DEBIAN_RUNTIME_PACKAGE_CONTROL_EXTRA ${CMAKE_BINARY_DIR}/debian-control/triggers)
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)
# Components that have files are packaged; `python` appears once python/ installs into it.

set(CPACK_DEBIAN_RUNTIME_PACKAGE_NAME terracl)
set(CPACK_DEBIAN_RUNTIME_PACKAGE_SECTION science)
# The kernels are OpenCL C compiled at run time: an ICD (a GPU driver, or PoCL on the CPU) is needed.
set(CPACK_DEBIAN_RUNTIME_PACKAGE_RECOMMENDS "pocl-opencl-icd | opencl-icd")
set(CPACK_DEBIAN_PACKAGE_GENERATE_SHLIBS ON)  # a shlibs file for packages that link libterracl.so.0
set(CPACK_DEBIAN_PACKAGE_GENERATE_SHLIBS_POLICY ">=")
# Debian's Description: CPack puts the summary line first; extended lines of at most 80 characters.
set(CPACK_DEBIAN_RUNTIME_DESCRIPTION
    "The terracl command-line tool (stages, pipelines, the studio) and the shared\nlibrary libterracl.so.0.")

set(CPACK_DEBIAN_DEVELOPMENT_PACKAGE_NAME terracl-dev)
set(CPACK_DEBIAN_DEVELOPMENT_PACKAGE_SECTION libdevel)
# What the public headers include; the static library additionally needs the -dev packages of
# the libraries terracl uses inside (suggested, not required: the shared library does not).
set(CPACK_DEBIAN_DEVELOPMENT_PACKAGE_DEPENDS
    "terracl (= ${PROJECT_VERSION}), ocl-icd-opencl-dev, opencl-clhpp-headers, nlohmann-json3-dev, libfmt-dev, libeigen3-dev")
set(CPACK_DEBIAN_DEVELOPMENT_PACKAGE_SUGGESTS
    "libgdal-dev, libpng-dev, libopenexr-dev, libflann-dev, libtinygltf-dev, liblz4-dev, libcpp-httplib-dev")
set(CPACK_DEBIAN_DEVELOPMENT_DESCRIPTION
    "Headers, the static library and the CMake package (find_package(terracl)).")

set(CPACK_DEBIAN_PYTHON_PACKAGE_NAME python3-terracl)
set(CPACK_DEBIAN_PYTHON_PACKAGE_SECTION python)
set(CPACK_DEBIAN_PYTHON_PACKAGE_DEPENDS "python3, python3-numpy")
set(CPACK_DEBIAN_PYTHON_DESCRIPTION "The terracl Python module (numpy arrays, rasterio and xarray georeferencing).")

include(CPack)
