#pragma once
// The command table: each subcommand registers its options on a CLI11
// sub-app and returns the function that runs it (COLMAP-style).

#include <functional>
#include <vector>

#include <CLI/CLI.hpp>

namespace tactres::cli {

struct Command {
  const char* name;
  const char* summary;
  // Declares options on `app` and returns the runner, which returns an exit
  // code. Runners may throw std::invalid_argument (usage, exit 3) or
  // std::runtime_error (I/O, exit 3); main() turns both into a message.
  std::function<std::function<int()>(CLI::App& app)> define;
};

Command generate_command();
Command simulate_command();
Command measure_command();
Command report_command();
Command watch_command();
Command bench_command();

// Every subcommand, in the order `tactres --help` lists them.
std::vector<Command> command_table();

}  // namespace tactres::cli
