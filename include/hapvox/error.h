#pragma once
// The one exception type for bad input (files, traces, options): what() is the one line
// `hapvox` prints after "hapvox: error: " for the same input, "SOURCE: PROBLEM", where
// SOURCE names the file or flag. Anything else thrown is hapvox's fault, not the input's.

#include <stdexcept>
#include <string>
#include <utility>

namespace hapvox {

/// A problem with something the user gave: what() reads "SOURCE: PROBLEM".
class InputError : public std::runtime_error {
 public:
  InputError(std::string source, std::string problem)
      : std::runtime_error(source + ": " + problem),
        source_(std::move(source)),
        problem_(std::move(problem)) {}

  /// The file or flag at fault, e.g. "trace.csv" or "--youngs-modulus-pa".
  const std::string& source() const { return source_; }
  /// What is wrong with it.
  const std::string& problem() const { return problem_; }

 private:
  std::string source_;
  std::string problem_;
};

}  // namespace hapvox
