// Python module entry point: each area binds itself from its own file.
#include "bindings.hpp"

PYBIND11_MODULE(_hysteron, m) {
  m.doc() = "hysteron: hysteresis models, exact inverses, identification and control of pneumatic muscles";
  hysteron::python::bind_models(m);
  hysteron::python::bind_more(m);
}
