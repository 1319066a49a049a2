// Outputs are all-or-nothing: a set of files is written into a staging folder beside them and
// swapped in whole when complete, so that a failed or interrupted run never leaves a file that
// looks finished, and a rerun replaces the whole earlier set. The output folder is locked while a
// run writes into it.
#pragma once

#include <string>
#include <vector>

namespace stillmap {

// "dir/name.ext" -> "dir/.name.ext.tmp" (hidden, and clearly not a finished output).
std::string TemporaryPathFor(const std::string& path);

// Renames `temporary` to `final_path`; throws std::runtime_error naming both on failure.
void CommitTemporary(const std::string& temporary, const std::string& final_path);

// A set of outputs written together into one folder.
//
// The constructor creates the folder when needed, locks it (a second run into it is refused),
// restores what an interrupted earlier run left (its staging folder is removed; a swap stopped
// half-way is rolled back to the earlier set) and creates an empty staging folder. Files are
// written to TemporaryPath(name); Commit() moves every earlier file of `owned_names` aside, moves
// the staged files in, and only then deletes the earlier ones (rolled back on any failure).
// Destroying the set without Commit() removes the staging folder, and the output folder itself
// when this run created it.
class OutputSet {
 public:
  // `owned_names`: every top-level name (file or folder, folders with a trailing '/') a run of
  // this kind may write; earlier outputs of these names are replaced, nothing else is touched.
  // Throws InputError naming the folder when it cannot be created or written, is locked by another
  // run, or holds a folder where an output file goes (or the reverse).
  OutputSet(std::string dir, std::vector<std::string> owned_names);
  ~OutputSet();
  OutputSet(const OutputSet&) = delete;
  OutputSet& operator=(const OutputSet&) = delete;

  // The staging path of `name` (a path relative to the folder; parent folders are created).
  std::string TemporaryPath(const std::string& name);
  // The final path of `name` inside the folder.
  std::string FinalPath(const std::string& name) const;
  // The staging folder (files written there by other means are committed too).
  const std::string& staging_dir() const { return staging_; }
  // Swaps the staged set in. Throws std::runtime_error (after rolling back) when a rename fails.
  void Commit();
  // Non-empty when the constructor restored an interrupted earlier run's outputs: what it did.
  const std::string& recovery_note() const { return recovery_note_; }
  // The entries of the folder that are neither the set's names nor its hidden entries (files a
  // user put there), sorted; they are never touched.
  std::vector<std::string> ForeignNames() const;

  // Whether `filename` (inside an output folder) is one of the set's own hidden entries.
  static bool IsInternalName(const std::string& filename);

 private:
  void Recover();  // see the constructor
  void Release();  // unlocks; removes the folder when this run created it and committed nothing

  std::string dir_;
  std::vector<std::string> owned_names_;
  std::string staging_;
  std::string recovery_note_;
  int lock_fd_ = -1;
  bool created_dir_ = false;
  bool committed_ = false;
};

}  // namespace stillmap
