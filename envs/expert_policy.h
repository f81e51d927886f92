#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "io/config_schema.h"

// A trained expert as plain Eigen: observation normalisation, a tanh MLP giving the mean
// action, and a state-independent log-std. PPO (maps/rl) trains it; envs/ only runs it, so
// envs/ needs no autograd.
namespace maps::envs {

struct ExpertPolicy {
  std::string task;                      // the task it was trained on, e.g. "gravity/0.5"
  Eigen::VectorXd obs_mean;              // running mean of observations seen in training
  Eigen::VectorXd obs_var;               // running variance
  double obs_clip = 10.0;                // normalised observations are clipped to [-clip, clip]
  double obs_epsilon = 1e-8;             // normalised = (obs - mean) / sqrt(var + epsilon)
  std::vector<Eigen::MatrixXd> weights;  // layer i: [out, in]
  std::vector<Eigen::VectorXd> biases;   // layer i: [out]
  Eigen::VectorXd log_std;               // [action size]
  std::string metadata_json = "{}";      // free-form: training steps, seed, measured return, ...

  int observation_size() const;
  int action_size() const;

  Eigen::VectorXd normalize(const Eigen::VectorXd& obs) const;
  // The deterministic action: tanh on every hidden layer, linear output (not clipped; the env clips).
  Eigen::VectorXd mean_action(const Eigen::VectorXd& obs) const;
  // mean_action + exp(log_std) * N(0, I).
  Eigen::VectorXd sample_action(const Eigen::VectorXd& obs, std::mt19937_64& rng) const;

  // Throws with a message naming what is inconsistent (sizes of layers, normalisation, log_std).
  void validate() const;

  // JSON file; written atomically (temporary file, then rename). load() validates and names
  // the file and what is wrong on a missing, truncated or inconsistent file.
  void save(const std::string& path) const;
  static ExpertPolicy load(const std::string& path);
};

// The keys of an expert file, with their types and ranges (`maps schema expert`); load() checks each through it and
// refuses a key outside it. "layers" (a list of {"weight": rows of numbers, "bias": numbers}) is checked by shape.
const std::vector<io::Field>& expert_file_schema();

}  // namespace maps::envs
