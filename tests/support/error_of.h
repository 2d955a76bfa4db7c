// The message of the std::exception a piece of code throws, for tests that check what an error says.
#pragma once

#include <gtest/gtest.h>

#include <exception>
#include <string>

namespace kiln::test {

// What `fn` throws, as e.what(); fails the test (and returns "") if it throws nothing.
template <class Fn>
std::string error_of(Fn fn) {
  try {
    fn();
  } catch (const std::exception& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected an exception";
  return "";
}

}  // namespace kiln::test
