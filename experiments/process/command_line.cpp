#include "experiments/process/command_line.h"

#include <string>

namespace maps::experiments {
namespace {

std::string& stored_command_line() {
  static std::string line;
  return line;
}

// The argument as a POSIX shell reads it back: bare when it holds only safe characters, else single-quoted.
std::string shell_quoted(const std::string& argument) {
  const bool safe = !argument.empty() && argument.find_first_not_of(
                                             "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                             "0123456789@%+=:,./_-") == std::string::npos;
  if (safe) return argument;
  std::string quoted = "'";
  for (char c : argument) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return quoted + "'";
}

}  // namespace

void set_command_line(int argc, char** argv) {
  std::string line;
  for (int i = 0; i < argc; ++i) {
    if (i > 0) line += ' ';
    line += shell_quoted(argv[i]);
  }
  stored_command_line() = line;
}

const std::string& command_line() { return stored_command_line(); }

}  // namespace maps::experiments
