#pragma once

#include <ostream>
#include <streambuf>

// An ostream writing to two others at once: the tool's progress to the terminal and to the run folder's log.
namespace maps::experiments {

class TeeBuffer : public std::streambuf {
 public:
  TeeBuffer(std::streambuf* first, std::streambuf* second) : first_(first), second_(second) {}

 protected:
  int overflow(int c) override {
    if (c == traits_type::eof()) return traits_type::not_eof(c);
    const bool a = first_->sputc(static_cast<char>(c)) != traits_type::eof();
    const bool b = second_->sputc(static_cast<char>(c)) != traits_type::eof();
    return a && b ? c : traits_type::eof();
  }
  std::streamsize xsputn(const char* s, std::streamsize n) override {
    const std::streamsize a = first_->sputn(s, n), b = second_->sputn(s, n);
    return a < b ? a : b;
  }
  int sync() override { return first_->pubsync() == 0 && second_->pubsync() == 0 ? 0 : -1; }

 private:
  std::streambuf* first_;
  std::streambuf* second_;
};

class TeeStream : public std::ostream {
 public:
  TeeStream(std::ostream& first, std::ostream& second)
      : std::ostream(&buffer_), buffer_(first.rdbuf(), second.rdbuf()) {}

 private:
  TeeBuffer buffer_;
};

}  // namespace maps::experiments
