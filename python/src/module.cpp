// Python module entry point: each area binds itself from its own file.
#include <glog/logging.h>

#include <cstdlib>
#include <string_view>

#include "bindings.hpp"

namespace {

// Ceres logs through glog; its lines (e.g. with GLOG_v=10 in the environment, or a
// covariance warning) must not reach a Python user's terminal: hysteron reports what matters
// itself, as the CLI does (apps/main.cpp). Only FATAL is kept. glog's flags are process-wide,
// so a process that initialised glog itself (google::InitGoogleLogging) before importing
// hysteron keeps its settings, and HYSTERON_KEEP_GLOG=1 in the environment leaves glog alone.
void silence_glog() {
  const char* keep = std::getenv("HYSTERON_KEEP_GLOG");
  if (keep && *keep && std::string_view(keep) != "0") return;
  if (google::IsGoogleLoggingInitialized()) return;
  FLAGS_minloglevel = google::GLOG_FATAL;
  FLAGS_logtostderr = false;
  FLAGS_alsologtostderr = false;
  FLAGS_stderrthreshold = google::GLOG_FATAL;
}

}  // namespace

PYBIND11_MODULE(_hysteron, m) {
  silence_glog();
  m.doc() = "hysteron: hysteresis models, exact inverses, identification and control of pneumatic muscles";
  hysteron::python::bind_models(m);
  hysteron::python::bind_more(m);
}
