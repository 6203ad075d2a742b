// SPDX-License-Identifier: Apache-2.0
// Library exceptions as Python exceptions carrying the stage and the message:
//   terracl.Error(RuntimeError) .stage .message;  terracl.UsageError(Error, ValueError);
//   terracl.Cancelled(Error) (a progress callback returned False or raised; Ctrl-C raises KeyboardInterrupt);
//   terracl.MissingFileError(Error, FileNotFoundError) .filename (an input that does not exist).
// OpenCL errors become terracl.Error with stage "opencl", as the CLI prints them.
#include "common.hpp"

#include <terracl/version.hpp>

#include <cerrno>

namespace terracl::python {
namespace {

PyObject* g_error = nullptr;
PyObject* g_usage = nullptr;
PyObject* g_cancelled = nullptr;
PyObject* g_missing = nullptr;

void set_error(PyObject* type, const std::string& stage, const std::string& full, const std::string& filename = {}) {
  const std::string prefix = stage + ": ";
  const std::string message = full.rfind(prefix, 0) == 0 ? full.substr(prefix.size()) : full;
  py::object exc = py::reinterpret_borrow<py::object>(type)(py::str(full));
  exc.attr("stage") = stage;
  exc.attr("message") = message;
  if (!filename.empty()) {  // OSError's fields, as open() fills them
    exc.attr("filename") = filename;
    exc.attr("errno") = ENOENT;
  }
  PyErr_SetObject(type, exc.ptr());
}

}  // namespace

PyObject* cancelled_type() { return g_cancelled; }

void init_errors(py::module_& m) {
  // Leaked on purpose: the types live as long as the interpreter (pybind11's own idiom).
  g_error = PyErr_NewExceptionWithDoc("terracl.Error",
                                      "A terracl stage failed; .stage names it, .message says what went wrong.",
                                      PyExc_RuntimeError, nullptr);
  py::tuple usage_bases = py::make_tuple(py::handle(g_error), py::handle(PyExc_ValueError));
  g_usage = PyErr_NewExceptionWithDoc("terracl.UsageError", "Bad options or arguments (the CLI exits 2 for these).",
                                      usage_bases.ptr(), nullptr);
  g_cancelled = PyErr_NewExceptionWithDoc(
      "terracl.Cancelled", "A progress callback returned False or raised (chained as __cause__).", g_error,
      nullptr);
  py::tuple missing_bases = py::make_tuple(py::handle(g_error), py::handle(PyExc_FileNotFoundError));
  g_missing = PyErr_NewExceptionWithDoc("terracl.MissingFileError",
                                        "An input file does not exist (a FileNotFoundError; .filename names it).",
                                        missing_bases.ptr(), nullptr);
  m.attr("Error") = py::handle(g_error);
  m.attr("MissingFileError") = py::handle(g_missing);
  m.attr("UsageError") = py::handle(g_usage);
  m.attr("Cancelled") = py::handle(g_cancelled);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const Cancelled& e) {
      set_error(g_cancelled, e.stage(), e.what());
    } catch (const MissingInputError& e) {
      set_error(g_missing, e.stage(), e.what(), e.path());
    } catch (const UsageError& e) {
      set_error(g_usage, e.stage(), e.what());
    } catch (const MissingFileError& e) {
      set_error(g_missing, e.stage(), e.what(), e.path());
    } catch (const Error& e) {
      set_error(g_error, e.stage(), e.what());
    } catch (const cl::Error& e) {
      set_error(g_error, "opencl", "opencl: " + describe(e));
    }
  });
}

Metadata provenance(const std::string& what) {
  return {{"terracl:version", terracl::version()}, {"terracl:command", "python: " + what}};
}

}  // namespace terracl::python
