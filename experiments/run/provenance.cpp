#include "experiments/run/provenance.h"

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
#include "experiments/process/command_line.h"
#include "experiments/process/cpu_model.h"
#include "experiments/process/host.h"
#include "experiments/process/version.h"
#include "experiments/run/plugins.h"
#include "experiments/run/run_folder.h"

namespace maps::experiments {

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
  // The code from outside the tree that this process ran: each plugin's file, its digest and what it registered.
  for (const LoadedPlugin& plugin : loaded_plugins())
    record["plugins"].push_back({{"path", plugin.path},
                                 {"sha256", plugin.sha256},
                                 {"built_against", plugin.version},
                                 {"registered", plugin.registered}});
  record.update(extra);
  return record;
}

void append_provenance(const std::string& run_dir, const nlohmann::json& record) {
  const std::string path = (std::filesystem::path(run_dir) / run_files::kProvenance).string();
  nlohmann::json records = nlohmann::json::array();
  if (std::filesystem::exists(path)) {
    records = read_json_file(path);
    if (!records.is_array()) throw std::runtime_error("'" + path + "' is not a JSON array of provenance records");
  }
  records.push_back(record);
  write_json_file(path, records);
}

}  // namespace maps::experiments
