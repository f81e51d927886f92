#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <string>

// What the demo file's writer, reader and checks share about the format (envs/demo_file.h describes the layout).
// Internal to envs/demo_file/.
namespace maps::envs::demo_file_detail {

using RowMatrixXd = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// 1: obs a dataset, no next_obs (2026-11 and before). 2: robomimic's layout: obs and next_obs groups of named
// arrays (one key, "flat"), data attribute env_args, per-demo episode_end.
constexpr std::int64_t kFormatVersion = 2;
constexpr const char* kObsKey = "flat";

// Where the first non-finite value of a matrix is, as "row r, column c" (or "" if all finite).
template <typename Derived>
std::string first_non_finite(const Eigen::DenseBase<Derived>& m, bool vector) {
  for (Eigen::Index r = 0; r < m.rows(); ++r)
    for (Eigen::Index c = 0; c < m.cols(); ++c)
      if (!std::isfinite(m(r, c))) {
        const std::string what = std::isnan(m(r, c)) ? "NaN" : "infinite value";
        return what + (vector ? " at step " + std::to_string(r)
                              : " at row " + std::to_string(r) + ", column " + std::to_string(c));
      }
  return "";
}

}  // namespace maps::envs::demo_file_detail
