#pragma once
// Typed errors for user input (files, traces, configs, flags). Invariants use CHECKs
// (engine/check.h) instead: an InputError is the user's to fix, a failed CHECK is ours.

#include <stdexcept>
#include <string>

namespace hapvox {

/// A problem with something the user gave us. what() reads "SOURCE: PROBLEM", where
/// SOURCE names the file (or flag) and PROBLEM says what is wrong with it.
class InputError : public std::runtime_error {
 public:
  InputError(std::string source, std::string problem)
      : std::runtime_error(source + ": " + problem),
        source_(std::move(source)),
        problem_(std::move(problem)) {}

  const std::string& source() const { return source_; }
  const std::string& problem() const { return problem_; }

 private:
  std::string source_;
  std::string problem_;
};

}  // namespace hapvox
