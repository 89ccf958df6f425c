// The message an error carries, for tests that assert what a bad input is told.
#pragma once

#include <exception>
#include <string>

#include "common/config_section.h"

namespace ragdoll {

// The message of the ConfigError `f` throws, or "" when it throws none (another exception
// escapes and fails the test).
template <typename F>
std::string ConfigErrorOf(F f) {
  try {
    f();
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

// The message of any exception `f` throws, or "" when it throws none.
template <typename F>
std::string ErrorOf(F f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

}  // namespace ragdoll
