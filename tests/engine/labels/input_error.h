#pragma once
// The message of the InputError a piece of code throws, for asserting it in full.

#include <gtest/gtest.h>

#include <string>

#include "engine/errors.h"

namespace hapvox::testing {

/// Runs `body`, expects an InputError, and returns its what() ("" and a failure when none).
template <typename F>
std::string input_error_of(F&& body) {
  try {
    body();
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "no InputError thrown";
  return "";
}

}  // namespace hapvox::testing
