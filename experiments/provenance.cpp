#include "experiments/provenance.h"

#include <openssl/evp.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <memory>
#include <stdexcept>
#include <vector>

#include "autograd/ops.h"
#include "experiments/cpu_model.h"
#include "experiments/run_folder.h"
#include "experiments/version.h"

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

std::string utc_now() {
  const std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm utc{};
  gmtime_r(&now, &utc);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &utc);
  return text;
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

std::string sha256_of_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read '" + path + "' to fingerprint it");
  const std::unique_ptr<EVP_MD_CTX, decltype(&EVP_MD_CTX_free)> context(EVP_MD_CTX_new(), EVP_MD_CTX_free);
  if (!context || EVP_DigestInit_ex(context.get(), EVP_sha256(), nullptr) != 1)
    throw std::runtime_error("OpenSSL could not start a SHA-256 digest");
  std::vector<char> buffer(1 << 20);
  while (in) {
    in.read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
    if (in.gcount() > 0) EVP_DigestUpdate(context.get(), buffer.data(), static_cast<std::size_t>(in.gcount()));
  }
  if (in.bad()) throw std::runtime_error("reading '" + path + "' failed while fingerprinting it");
  std::array<unsigned char, EVP_MAX_MD_SIZE> digest{};
  unsigned int length = 0;
  EVP_DigestFinal_ex(context.get(), digest.data(), &length);
  static const char* hex = "0123456789abcdef";
  std::string text;
  for (unsigned int i = 0; i < length; ++i) {
    text += hex[digest[i] >> 4];
    text += hex[digest[i] & 15];
  }
  return text;
}

nlohmann::json provenance_record(const nlohmann::json& extra) {
  char host[256] = {};
  if (gethostname(host, sizeof host - 1) != 0) host[0] = '\0';
  std::error_code error;
  const std::filesystem::path cwd = std::filesystem::current_path(error);
  nlohmann::json record{{"tool_version", tool_version()},
                        {"git_commit", tool_git_commit()},
                        {"started_utc", utc_now()},
                        {"command_line", command_line()},
                        {"working_directory", error ? std::string() : cwd.string()},
                        {"host", std::string(host)},
                        {"cpu", cpu_model()},
                        {"float32_gemm_kernel", ag::float32_gemm_kernel()}};
  record.update(extra);
  return record;
}

void append_provenance(const std::string& run_dir, const nlohmann::json& record) {
  const std::string path = (std::filesystem::path(run_dir) / "provenance.json").string();
  nlohmann::json records = nlohmann::json::array();
  if (std::filesystem::exists(path)) {
    records = read_json_file(path);
    if (!records.is_array()) throw std::runtime_error("'" + path + "' is not a JSON array of provenance records");
  }
  records.push_back(record);
  write_json_file(path, records);
}

}  // namespace maps::experiments
