#pragma once
// The documented exit codes of every tactres subcommand (README, "Exit codes").

namespace tactres::cli {

enum ExitCode : int {
  kExitOk = 0,              // done, and within spec
  kExitBelowSpec = 1,       // a measured limit is below a --require-* limit
  kExitUnusableInput = 2,   // unusable input, or no target found
  kExitUsageOrIo = 3,       // bad arguments, malformed files, or an I/O error
};

}  // namespace tactres::cli
