// SPDX-License-Identifier: Apache-2.0
// terracl._terracl: the compiled half of the `terracl` Python package (python/terracl/ holds the
// pure-Python half: stage functions with keyword options, docs). One init function per area.
#include "common.hpp"

#include <terracl/version.hpp>

PYBIND11_MODULE(_terracl, m) {
  m.doc() = "terracl: terrain authoring in the gradient domain on OpenCL devices (compiled core)";
  m.attr("__version__") = terracl::version();
  terracl::python::init_errors(m);
  terracl::python::init_devices(m);
  terracl::python::init_arrays(m);
  terracl::python::init_stages(m);
  terracl::python::init_session(m);
}
