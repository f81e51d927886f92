#pragma once

#include <exception>
#include <string>

// The message of what fn throws, or "<no exception>" (for tests that match parts of an error message).
template <typename Fn>
std::string error_of(Fn&& fn) {
  try {
    fn();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "<no exception>";
}
