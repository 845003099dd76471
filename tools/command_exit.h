#pragma once
// A command's outcome as an exit status of its own (`hapvox sweep`: 100 + the rows that
// failed, 130 when interrupted), thrown once everything is written and printed; main()
// returns it. Not an error: nothing more is printed.

namespace hapvox::cli {

struct CommandExit {
  int status = 0;
};

}  // namespace hapvox::cli
