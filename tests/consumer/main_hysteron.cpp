// hysteron::hysteron (every layer): a model file written and read back.
#include <hysteron/io/model_file.hpp>
#include <hysteron/report.hpp>

#include <cstdio>
#include <filesystem>

int main() {
  hysteron::PiParams pi;
  pi.r = {0.0, 0.2};
  pi.p = {1.0, 0.5};
  const auto path = (std::filesystem::temp_directory_path() / "hysteron_consumer_model.json").string();
  hysteron::io::write_model_file(path, pi);
  const hysteron::ModelParams back = hysteron::io::read_model_file(path);
  std::filesystem::remove(path);
  hysteron::Model a(pi), b(back);
  const bool same = a.step(0.3) == b.step(0.3);
  std::printf("consumer hysteron: model file round trip %s\n", same ? "ok" : "differs");
  return same ? 0 : 1;
}
