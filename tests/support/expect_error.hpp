#pragma once
/// Assertions on error messages: that a call throws InputError and what the message says.
#include <gtest/gtest.h>

#include <string>
#include <utility>

#include "core/error.hpp"

/// Expects `text` to contain `needle`, printing both when it does not.
#define EXPECT_CONTAINS(text, needle)                                                   \
  EXPECT_NE(std::string(text).find(needle), std::string::npos)                          \
      << "'" << (text) << "' lacks '" << (needle) << "'"

namespace planecell::test {

/// Runs `fn`, returns the message of the `Error` it throws; records a failure when it throws
/// none.
template <class Error, class Fn>
std::string error_of(Fn&& fn) {
  try {
    fn();
  } catch (const Error& e) {
    return e.what();
  }
  ADD_FAILURE() << "no exception of the expected type";
  return {};
}

/// error_of<InputError>.
template <class Fn>
std::string input_error_of(Fn&& fn) {
  return error_of<InputError>(std::forward<Fn>(fn));
}

}  // namespace planecell::test
