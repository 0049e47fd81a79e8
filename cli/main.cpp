// tactres: resolution metrology for optical tactile sensors.
#include <cstdio>
#include <exception>
#include <stdexcept>

#include <fmt/format.h>
#include <glog/logging.h>

#include "command.h"
#include "exit_codes.h"

namespace tactres::cli {

std::vector<Command> command_table() {
  return {generate_command(), simulate_command(), measure_command(), report_command(), watch_command(), bench_command()};
}

}  // namespace tactres::cli

int main(int argc, char** argv) {
  using namespace tactres::cli;
  // Ceres logs through glog; tactres reports solver failures as data, so
  // only fatal messages may reach the terminal.
  FLAGS_minloglevel = 3;
  google::InitGoogleLogging(argv[0]);
  CLI::App app{
      "tactres " TACTRES_VERSION
      ": how fine a detail does an optical tactile sensor resolve, in lp/mm?\n"
      "Exit codes: 0 ok / within spec, 1 below a --require-* limit, 2 unusable input or no\n"
      "target found, 3 usage or I/O error.",
      "tactres"};
  app.set_version_flag("--version", TACTRES_VERSION);
  app.require_subcommand(1);

  std::vector<std::pair<CLI::App*, std::function<int()>>> runners;
  for (const Command& c : command_table()) {
    CLI::App* sub = app.add_subcommand(c.name, c.summary);
    runners.emplace_back(sub, c.define(*sub));
  }

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? kExitOk : kExitUsageOrIo;
  }

  for (auto& [sub, run] : runners) {
    if (!sub->parsed()) continue;
    try {
      return run();
    } catch (const std::invalid_argument& e) {
      fmt::print(stderr, "tactres {}: error: {}\n", sub->get_name(), e.what());
      return kExitUsageOrIo;
    } catch (const std::exception& e) {
      fmt::print(stderr, "tactres {}: error: {}\n", sub->get_name(), e.what());
      return kExitUsageOrIo;
    }
  }
  return kExitUsageOrIo;
}
