#include "experiments/process/cpu_model.h"

#include <gtest/gtest.h>

#include <sstream>

namespace maps::experiments {
namespace {

std::string model_of(const std::string& text) {
  std::istringstream in(text);
  return cpu_model_from(in);
}

TEST(CpuModel, FirstModelNameLineTrimmed) {
  EXPECT_EQ(model_of("processor\t: 0\nvendor_id\t: AuthenticAMD\nmodel\t\t: 1\nmodel name\t: AMD EPYC  \n"
                     "model name\t: Other CPU\n"),
            "AMD EPYC");
  EXPECT_EQ(model_of("model name\t: Intel(R) Xeon(R) Processor"), "Intel(R) Xeon(R) Processor");  // no final newline
}

TEST(CpuModel, CarriageReturnsAreNotPartOfTheName) {
  EXPECT_EQ(model_of("model name\t: AMD EPYC\r\nflags\t: avx2\r\n"), "AMD EPYC");
}

TEST(CpuModel, NoModelNameGivesEmpty) {
  EXPECT_EQ(model_of(""), "");
  // ARM's cpuinfo has no "model name"; "model" alone is the model number, not a name.
  EXPECT_EQ(model_of("processor\t: 0\nmodel\t\t: 1\nCPU implementer\t: 0x41\n"), "");
  EXPECT_EQ(model_of("model name\n"), "");  // no colon: not a value
}

TEST(CpuModel, EmptyValueGivesEmpty) {
  EXPECT_EQ(model_of("model name\t:\n"), "");
  EXPECT_EQ(model_of("model name\t:   \t\r\n"), "");
}

TEST(CpuModel, UnreadableOrNamelessFileIsUnknown) {
  EXPECT_EQ(cpu_model_at("/nonexistent/cpuinfo"), "unknown");
  EXPECT_EQ(cpu_model_at("/dev/null"), "unknown");
  EXPECT_FALSE(cpu_model().empty());
}

}  // namespace
}  // namespace maps::experiments
