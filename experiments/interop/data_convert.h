#pragma once

#include <string>

// `maps data export|import`: demo files to and from D4RL, Minari and robomimic (experiments/interop/formats.py does
// the conversion with h5py; docs/interop.md says what each format keeps and drops).
namespace maps::experiments {

struct DataConvertOptions {
  std::string format;      // d4rl, minari or robomimic
  std::string input;       // export: a demo file; import: the other format's file (Minari: its dataset folder)
  std::string out;         // export: the other format's file or folder; import: a demo file
  bool force = false;      // import: replace an existing --out demo file
  std::string task_set;    // import: the set name given to a dataset made elsewhere
  std::string obs_keys;    // import from robomimic: observation keys, comma-separated, in column order
  std::string dataset_id;  // export to Minari
};

// The input demo file is read (and so checked) before the script runs; an imported file is read back after it,
// and removed if this project's reader refuses it.
int run_data_export(const DataConvertOptions& options);
int run_data_import(const DataConvertOptions& options);

}  // namespace maps::experiments
