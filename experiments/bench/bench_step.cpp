#include "experiments/bench/bench_step.h"

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "autograd/autograd.h"
#include "experiments/bench/bench_request.h"
#include "experiments/process/cpu_model.h"
#include "experiments/process/host.h"
#include "experiments/process/plugins.h"
#include "experiments/run/provenance.h"
#include "experiments/run/run_folder.h"
#include "maps/policies/maps_flops.h"
#include "maps/policies/maps_policy.h"
#include "maps/training/run_config.h"
#include "nn/optim/adam.h"

namespace maps::experiments {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

struct SetShapes {
  const char* name;
  core::PolicyShape shape;  // S, A, K
  std::int64_t per_task;
};

// The paper's shapes (issue 6): HalfCheetah's 17 observations and 6 actions, Meta-World's 39 and 4.
constexpr std::array<SetShapes, 3> kSets{{
    {"gravity", {17, 6, 5}, 128},
    {"modified", {17, 6, 11}, 128},
    {"mt10", {39, 4, 10}, 32},
}};

const SetShapes& shapes_of(const std::string& set) {
  std::string known;
  for (const auto& s : kSets) {
    if (set == s.name) return s;
    known += (known.empty() ? "" : ", ") + std::string(s.name);
  }
  throw std::invalid_argument("bench step: unknown --set '" + set + "'; expected one of " + known);
}

// The float32 GEMM on 1024^3, the machine's ceiling, two ways: Eigen's (one product per thread, on its share of the
// rows; the reference) and maps's own kernel (ag::matmul, which the step runs on; faster than Eigen's on
// this CPU, so the step is also judged against it).
class GemmCeiling {
 public:
  explicit GemmCeiling(int threads)
      : threads_(threads),
        a_(RowMatrixF::Random(kSize, kSize)),
        b_(RowMatrixF::Random(kSize, kSize)),
        c_(kSize, kSize),
        own_a_(ag::from_eigen(a_.cast<double>()).to(ag::Dtype::Float32)),
        own_b_(ag::from_eigen(b_.cast<double>()).to(ag::Dtype::Float32)) {}
  // Times one product of maps's kernel (seconds).
  double time_own() {
    ag::NoGradGuard no_grad;
    const auto t0 = Clock::now();
    const ag::Tensor c = ag::matmul(own_a_, own_b_);
    const double seconds = seconds_since(t0);
    if (!std::isfinite(c.data<float>()[0]))
      throw std::runtime_error("bench step: the own GEMM reference produced a non-finite value");
    return seconds;
  }
  // Times one Eigen product (seconds).
  double time_one() {
    const auto t0 = Clock::now();
    if (threads_ == 1) {
      c_.noalias() = a_ * b_;
    } else {
      ag::parallel_for(threads_, 1, [&](std::int64_t first, std::int64_t last) {
        const std::int64_t r0 = kSize * first / threads_, r1 = kSize * last / threads_;
        c_.middleRows(r0, r1 - r0).noalias() = a_.middleRows(r0, r1 - r0) * b_;
      });
    }
    const double seconds = seconds_since(t0);
    if (!std::isfinite(c_(0, 0)))
      throw std::runtime_error("bench step: the GEMM reference produced a non-finite value");
    return seconds;
  }
  static double flops() { return 2.0 * kSize * kSize * kSize; }

 private:
  using RowMatrixF = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  static constexpr Eigen::Index kSize = 1024;
  int threads_;
  RowMatrixF a_, b_, c_;
  ag::Tensor own_a_, own_b_;
};

// A balanced batch of random standardised states (per_task rows per task, task-major), each with a nearby previous
// state, and random actions in [-1, 1].
core::Batch random_batch(const SetShapes& s, ag::Generator& gen) {
  const std::int64_t K = s.shape.num_tasks, n = K * s.per_task;
  core::Batch batch;
  batch.observations = ag::randn({n, s.shape.observation_size}, gen);
  batch.previous_observations = batch.observations.detach() + ag::randn({n, s.shape.observation_size}, gen) * 0.1;
  batch.actions = ag::rand({n, s.shape.action_size}, gen, ag::Dtype::Float32, -1.0, 1.0);
  batch.per_task = s.per_task;
  for (std::int64_t k = 0; k < K; ++k) batch.tasks.insert(batch.tasks.end(), static_cast<std::size_t>(s.per_task), k);
  return batch;
}

// experiments/bench/peer_pytorch.py beside this source file, else found walking up from the working directory.
fs::path peer_script() {
  const fs::path from_source = fs::path(__FILE__).parent_path() / "peer_pytorch.py";
  if (from_source.is_absolute() && fs::is_regular_file(from_source)) return from_source;
  std::error_code ec;
  for (fs::path dir = fs::current_path(ec); !ec && !dir.empty(); dir = dir.parent_path()) {
    const fs::path candidate = dir / "experiments" / "bench" / "peer_pytorch.py";
    if (fs::is_regular_file(candidate)) return candidate;
    if (dir == dir.root_path()) break;
  }
  throw std::runtime_error("bench step: cannot find experiments/bench/peer_pytorch.py (looked beside " +
                           from_source.string() + " and up from the working directory)");
}

// Runs the PyTorch peer for the set; its last stdout line is a JSON object. Returns a null json when it skipped.
nlohmann::json run_peer(const std::string& set, int threads, double seconds) {
  const std::string command = "/usr/bin/python3 '" + peer_script().string() + "' --set " + set + " --threads " +
                              std::to_string(threads) + " --seconds " + std::to_string(seconds) + " --json";
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) throw std::runtime_error("bench step: cannot run '" + command + "'");
  std::string output;
  std::array<char, 4096> chunk{};
  while (std::fgets(chunk.data(), static_cast<int>(chunk.size()), pipe) != nullptr) output += chunk.data();
  const int status = pclose(pipe);
  // The peer's last non-empty line is its JSON object.
  std::string last_line;
  for (std::size_t start = 0; start < output.size();) {
    const std::size_t end = std::min(output.find('\n', start), output.size());
    if (end > start) last_line = output.substr(start, end - start);
    start = end + 1;
  }
  const nlohmann::json result = nlohmann::json::parse(last_line, nullptr, /*allow_exceptions=*/false);
  if (status != 0 || !result.is_object())
    throw std::runtime_error("bench step: the PyTorch peer failed (exit status " + std::to_string(status) +
                             "): " + command + "\n" + output);
  if (result.contains("skipped")) {
    std::cerr << "bench step: PyTorch comparison skipped: " << result["skipped"].get<std::string>() << "\n";
    return nullptr;
  }
  return result;
}

}  // namespace

int run_bench_step(const BenchStepOptions& options) {
  const SetShapes& s = shapes_of(options.set);
  if (options.threads < 1) throw std::invalid_argument("bench step: --threads must be >= 1");
  if (!(options.seconds > 0.0)) throw std::invalid_argument("bench step: --seconds must be > 0");
  ag::set_num_threads(options.threads);

  // The method at its defaults (MAPS: the paper's model, M = 10, modules 3x128, selector 2x128, four losses; the
  // baselines 3x128; the zoo's methods at MAPS's parameter count), as `maps train` would build it.
  nlohmann::json request = bench_request(options.method, options.config_path, "bench step");
  if (!options.precision.empty()) request["train"]["precision"] = options.precision;
  const core::RunConfig run_config = parse_run_config_from(request, "bench step");
  const std::string& precision_name = run_config.train.precision;
  const ag::MatmulPrecision precision = ag::parse_matmul_precision(precision_name);
  if (const std::string refusal = ag::matmul_precision_refusal(precision, cpu_model()); !refusal.empty())
    throw std::invalid_argument("bench step: precision " + precision_name + " " + refusal);
  // The steps and the own GEMM reference alike; Eigen's reference stays float32.
  const ag::MatmulPrecisionGuard precision_guard(precision);
  const core::MAPSConfig& config = run_config.maps;
  if (options.vs_pytorch && options.method != "maps")
    throw std::invalid_argument(
        "bench step: --vs-pytorch times MAPS's step only (experiments/bench/"
        "peer_pytorch.py); drop it for --method " +
        options.method);
  const auto policy_pointer = core::make_policy(run_config, s.shape);
  core::Policy& policy = *policy_pointer;
  ag::Generator gen(0);
  policy.train();
  optim::Adam adam(policy.parameters(), {.lr = 1e-4});
  SetShapes batch_shapes = s;
  batch_shapes.per_task = policy.batch_per_task(s.per_task);
  batch_shapes.shape = policy.shape();  // a policy predicting chunks trains on chunks of actions
  const core::Batch batch = random_batch(batch_shapes, gen);
  // Seconds of the last step's phases: forward (the loss terms), backward, Adam.
  std::array<double, 3> phase{};
  auto step = [&] {
    const auto t0 = Clock::now();
    const core::LossTerms terms = policy.loss(batch);
    const auto t1 = Clock::now();
    adam.zero_grad();
    terms.total.backward();
    const auto t2 = Clock::now();
    adam.step();
    phase = {std::chrono::duration<double>(t1 - t0).count(), std::chrono::duration<double>(t2 - t1).count(),
             seconds_since(t2)};
    return terms.total.item();
  };

  GemmCeiling ceiling(options.threads);
  for (int i = 0; i < 5; ++i) step();  // warm-up: first allocations, Adam's state
  double counted_flops = 0.0;
  {
    const ag::GemmFlopCounter counter;
    step();
    counted_flops = counter.flops();
  }
  ceiling.time_one();
  ceiling.time_own();
  // Rounds of steps and GEMMs alternate, so both medians see the same clock and load: each round times a GEMM,
  // runs one step untimed (the GEMMs' 12 MB have just pushed the model out of cache; training does no such thing
  // between steps), then times steps for a tenth of the budget (at least 4).
  std::vector<double> times, gemm_times, own_gemm_times;
  std::array<std::vector<double>, 3> phases;
  const auto start = Clock::now();
  double last_loss = 0.0;
  while (times.size() < 10 || seconds_since(start) < options.seconds) {
    gemm_times.push_back(ceiling.time_one());
    own_gemm_times.push_back(ceiling.time_own());
    step();
    const auto round_start = Clock::now();
    for (int i = 0; i < 4 || seconds_since(round_start) < options.seconds / 10; ++i) {
      const auto t0 = Clock::now();
      last_loss = step();
      times.push_back(seconds_since(t0));
      for (std::size_t j = 0; j < phase.size(); ++j) phases[j].push_back(phase[j]);
    }
  }
  if (!std::isfinite(last_loss)) throw std::runtime_error("bench step: the loss became non-finite");
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  };
  const double step_seconds = median(times);
  const double forward_ms = median(phases[0]) * 1e3, backward_ms = median(phases[1]) * 1e3,
               adam_ms = median(phases[2]) * 1e3;
  // MAPS's work is counted analytically (maps_flops.h: what the step needs); another method's is the products it
  // ran, counted as they ran (for MAPS the two agree to within the products it need not run).
  const double flops =
      options.method == "maps" ? core::maps_training_step_flops(s.shape, config, s.per_task) : counted_flops;
  const double gflops = flops / step_seconds * 1e-9;
  const double gemm = GemmCeiling::flops() / median(gemm_times) * 1e-9;
  const double own_gemm = GemmCeiling::flops() / median(own_gemm_times) * 1e-9;

  nlohmann::json result{{"set", s.name},
                        {"method", options.method},
                        {"parameters", policy.parameter_count()},
                        {"gemm_gflop_counted", counted_flops * 1e-9},
                        {"threads", options.threads},
                        {"states", s.shape.num_tasks * s.per_task},
                        {"steps_timed", times.size()},
                        {"ms_per_step", step_seconds * 1e3},
                        {"forward_ms", forward_ms},
                        {"backward_ms", backward_ms},
                        {"adam_ms", adam_ms},
                        {"gflop_per_step", flops * 1e-9},
                        {"gflops", gflops},
                        {"gemm_gflops", gemm},
                        {"ratio_to_gemm", gflops / gemm},
                        {"own_gemm_gflops", own_gemm},
                        {"ratio_to_own_gemm", gflops / own_gemm},
                        {"float32_gemm_kernel", ag::float32_gemm_kernel()},
                        {"matmul_precision", precision_name},
                        {"cpu", cpu_model()}};
  if (options.method == "maps") result["selector_losses"] = core::to_json(run_config)["maps"]["selector_losses"];
  if (!run_config.plugins.empty()) result["plugins"] = run_config.plugins;
  if (options.vs_pytorch) {
    const nlohmann::json peer = run_peer(s.name, options.threads, options.seconds);
    if (!peer.is_null()) {
      result["pytorch_ms_per_step"] = peer.at("ms_per_step");
      result["pytorch_blas"] = peer.value("blas", "");
      result["speedup_vs_pytorch"] = peer.at("ms_per_step").get<double>() / (step_seconds * 1e3);
    }
  }
  if (options.json) {
    std::cout << result.dump() << std::endl;
    return 0;
  }
  char line[256];
  std::printf(
      "%s training step, set %s: %lld states (%lld tasks x %lld), S=%lld A=%lld, %lld parameters, %d thread%s\n",
      options.method.c_str(), s.name, static_cast<long long>(s.shape.num_tasks * s.per_task),
      static_cast<long long>(s.shape.num_tasks), static_cast<long long>(s.per_task),
      static_cast<long long>(s.shape.observation_size), static_cast<long long>(s.shape.action_size),
      static_cast<long long>(policy.parameter_count()), options.threads, options.threads == 1 ? "" : "s");
  std::cout << "  CPU: " << cpu_model() << "\n";
  std::cout << "  matrix products: " << precision_name << "\n";
  if (result.contains("selector_losses"))
    std::cout << "  selector losses: " << result["selector_losses"].dump() << "\n";
  std::snprintf(line, sizeof line, "  %.3f ms/step (median of %zu), %.3f GFLOP/step, %.1f GFLOP/s", step_seconds * 1e3,
                times.size(), flops * 1e-9, gflops);
  std::cout << line << "\n";
  std::snprintf(line, sizeof line, "  phases (medians): forward %.3f ms, backward %.3f ms, Adam %.3f ms", forward_ms,
                backward_ms, adam_ms);
  std::cout << line << "\n";
  std::snprintf(line, sizeof line,
                "  Eigen float32 GEMM 1024^3 (median of %zu, between rounds of steps, same threads): %.1f GFLOP/s; the "
                "step reaches %.2f of it",
                gemm_times.size(), gemm, gflops / gemm);
  std::cout << line << "\n";
  std::snprintf(line, sizeof line,
                "  maps's own %s GEMM 1024^3 (ag::matmul, kernel: %s; what the step runs on): %.1f GFLOP/s; the "
                "step reaches %.2f of it",
                precision_name.c_str(),
                precision == ag::MatmulPrecision::bf16 ? "maps AVX512-BF16" : ag::float32_gemm_kernel(), own_gemm,
                gflops / own_gemm);
  std::cout << line << "\n";
  if (result.contains("pytorch_ms_per_step")) {
    std::snprintf(line, sizeof line, "  PyTorch: %.3f ms/step; maps is %.2fx PyTorch",
                  result["pytorch_ms_per_step"].get<double>(), result["speedup_vs_pytorch"].get<double>());
    std::cout << line << "\n";
  }
  return 0;
}

}  // namespace maps::experiments
