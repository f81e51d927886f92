#pragma once

#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "experiments/suite/config.h"

// A suite's output folder (maps suite run --out DIR):
//   DIR/suite.json                       the config and every cell's identity and run config (maps-suite/1)
//   DIR/cells/<set>/<cell>/              a run folder (experiments/run/run_folder.h) plus:
//       request.json                     the run config the cell was started with
//       train.out, eval.log              the child processes' output
//       result.json                      written last, atomically: the cell is finished (maps-suite-cell/1)
//       error.json                       the last failure (stage, error, the log's tail)
//       .lock                            flock-ed by the process running the cell (released when it dies)
//       replaced/<time>/                 result.json and curve.csv of an earlier run of the cell (retire_cell)
// A result counts only when it parses, has the format, and names this cell with this run config; anything else
// in a cell folder is resumable work or damage, never a result.
namespace maps::experiments {

inline constexpr const char* kSuiteFormat = "maps-suite/1";
inline constexpr const char* kCellFormat = "maps-suite-cell/1";

// The files above, named once.
namespace suite_files {
inline constexpr char kManifest[] = "suite.json";
inline constexpr char kTrainOutput[] = "train.out";  // whatever the training child printed (a crash too)
inline constexpr char kEvalLog[] = "eval.log";
inline constexpr char kResult[] = "result.json";
inline constexpr char kError[] = "error.json";
inline constexpr char kLock[] = ".lock";
}  // namespace suite_files

std::filesystem::path cell_dir(const std::filesystem::path& out, const SuiteCell& cell);

// suite.json's content for these cells.
nlohmann::json suite_manifest(const Suite& suite, const std::vector<SuiteCell>& cells);
// Writes DIR/suite.json, or checks the one there: a cell of the same name must have the same run config (a suite
// may grow: more seeds or grids keep the finished cells). Throws naming the first conflicting cell.
void write_or_check_manifest(const std::filesystem::path& out, const Suite& suite);
// Reads DIR/suite.json back into a Suite (its cells and config), for status, merge and report.
Suite read_manifest(const std::filesystem::path& out);

// Whether two run configs are the same run once each is resolved (core::parse_run_config then to_json), so a folder
// written before a config key existed (its default then implied) still matches. An unparsable one matches nothing.
bool same_run_config(const nlohmann::json& a, const nlohmann::json& b);
// Where two run configs differ once resolved, for a message: up to three keys, each with both values
// ("maml.query_per_task: 40 in its config, 160 in the suite's"), then how many more; or which one is no run config.
std::string run_config_differences(const nlohmann::json& a, const nlohmann::json& b, const std::string& a_name,
                                   const std::string& b_name);

// Temporaries a killed writer left in dir (io::write_file_atomically's ".<name>.tmp-...", maps collect's
// "*.partial.h5"): removed by whoever holds the cell's lock, and never copied.
bool is_temporary(const std::filesystem::path& file);
void remove_temporaries(const std::filesystem::path& dir);

// The cell's result when it is a trustworthy one; std::nullopt when missing. `damage` (when given) gets why a
// result.json that exists was not trusted ("" when there is none or it is fine).
std::optional<nlohmann::json> read_result(const std::filesystem::path& dir, const SuiteCell& cell,
                                          std::string* damage = nullptr);

// An exclusive, non-blocking flock on dir/.lock; the destructor (or the process's death) releases it.
class CellLock {
 public:
  explicit CellLock(const std::filesystem::path& dir);
  ~CellLock();
  CellLock(const CellLock&) = delete;
  CellLock& operator=(const CellLock&) = delete;
  bool held() const { return fd_ >= 0; }

 private:
  int fd_ = -1;
};
// Whether some process holds dir/.lock now (a running cell).
bool cell_is_locked(const std::filesystem::path& dir);

// The folder of the cell a transfer cell starts from (init.run, relative to the cell's folder dir); empty when none.
std::filesystem::path source_dir(const std::filesystem::path& dir, const SuiteCell& cell);
// The checkpoint file in it that the cell starts from (init.checkpoint); empty when none.
std::filesystem::path source_checkpoint(const std::filesystem::path& dir, const SuiteCell& cell);

// Earlier results of a cell that was run again (retire_cell), each in a folder named for when it finished.
inline constexpr const char* kReplacedFolder = "replaced";

// Removes everything in dir but .lock and replaced/ (a damaged cell is redone from nothing).
void clear_cell(const std::filesystem::path& dir);
// The folder in dir/replaced/ for an earlier result that finished at `finished` (result.json's time; anything else
// gives "unknown"), suffixed -2, -3, ... past folders that hold a result.json already.
std::filesystem::path replaced_folder(const std::filesystem::path& dir, std::string finished);
// The entries of dir/replaced/ (each an earlier run's result.json and curve.csv), sorted by name, so in the order the
// runs finished; none without a replaced/ folder.
std::vector<std::filesystem::path> replaced_entries(const std::filesystem::path& dir);
// Moves a finished cell's result.json and curve.csv to dir/replaced/<its "finished" time>/ and clears the rest: the
// cell is to be run again and its earlier result stays on record. Returns that folder. The caller holds the lock.
std::filesystem::path retire_cell(const std::filesystem::path& dir);

// The cells that start from `source` (a cell folder under out), directly or through a chain of init.run: nearest
// first, each once (a cycle cannot loop). `dependants` maps a cell folder to the cells whose init.run names it.
std::vector<std::pair<std::filesystem::path, const SuiteCell*>> suite_descendants(
    const std::map<std::filesystem::path, std::vector<const SuiteCell*>>& dependants, const std::filesystem::path& out,
    const std::filesystem::path& source);

// The suite's cells in its order, but every cell after the cell its init.run names (a cycle keeps its order).
std::vector<const SuiteCell*> sources_first(const Suite& suite);

// A source cell (one that another cell starts from: init.run) that is finished but whose checkpoint is gone (the
// results are kept without checkpoints) while some cell that starts from it is not finished: the source and every
// finished cell that started from it, directly or through another (a chain of init.run), are retired (retire_cell:
// their results move to replaced/), so that the suite runs them again, the source first, and every cell of the group
// starts from the same run of its source; unfinished cells of the group start again from nothing. A group that
// another process holds any cell of is left alone: the cell folders of such groups are returned, for this process to
// leave to that one.
std::set<std::filesystem::path> retire_sources_without_checkpoint(const std::filesystem::path& out,
                                                                  const std::vector<const SuiteCell*>& cells);
// What retire_sources_without_checkpoint would do to `cells` (names in `finished` are finished), by cell name, with a
// source's checkpoint looked for in every folder of `dirs`: what `maps suite status` reports. With one folder it is
// exactly what `maps suite run --out` that folder does; with several (shards, or a clone beside the machine that ran
// it) a checkpoint in any of them counts, as after `maps suite merge`.
struct CellsRunAgain {
  std::set<std::string> finished;   // retired: their results move to replaced/ and they run again
  std::set<std::string> restarted;  // unfinished cells of those groups: cleared, they start from nothing
};
CellsRunAgain cells_to_run_again(const std::vector<const SuiteCell*>& cells, const std::set<std::string>& finished,
                                 const std::vector<std::filesystem::path>& dirs);

}  // namespace maps::experiments
