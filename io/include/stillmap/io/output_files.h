// Outputs are all-or-nothing: a set of files is written into a staging folder beside them and
// swapped in when complete, so that a failed or interrupted run never leaves a file that looks
// finished. A rerun replaces exactly the files the last run recorded writing, and nothing a user
// put in the folder is deleted or overwritten. The output folder is locked while a run writes.
#pragma once

#include <string>
#include <vector>

namespace stillmap {

// "dir/name.ext" -> "dir/.name.ext.tmp" (hidden, and clearly not a finished output).
std::string TemporaryPathFor(const std::string& path);

// Renames `temporary` to `final_path`; throws std::runtime_error naming both on failure.
void CommitTemporary(const std::string& temporary, const std::string& final_path);

// Completes a swap that a killed run of `kind` left half-done in `dir` (see OutputSet), unless
// another run holds the folder. Returns what it did ("" when nothing). Never throws; commands
// that read an output folder call it first.
std::string RecoverOutputFolder(const std::string& dir, const std::string& kind);

// A set of outputs written together into one folder.
//
// The folder keeps a record of the files the last committed run of this kind wrote
// (".stillmap-<kind>-outputs"). The constructor creates the folder when needed, locks it (a
// second run into it is refused), completes a swap an earlier run was killed in, and creates an
// empty staging folder. Files are written to TemporaryPath(name); Commit() first writes a journal
// of the swap, then moves each staged file over its final name (one atomic rename per file; a
// file there that no run recorded writing is first renamed aside, see SetAside), removes the
// recorded files of the last run that this one did not write, and writes the new record. A run
// killed at any point after the journal is rolled forward by the next command that opens the
// folder, so no output is ever missing. Destroying the set without Commit() removes the staging
// folder, and the output folder itself when this run created it.
class OutputSet {
 public:
  // A file of the folder that shares an output's name but was not written by a stillmap run of
  // this kind: Commit() keeps it under `kept_as` (both relative to the folder).
  struct SetAside {
    std::string name;
    std::string kept_as;
  };

  // `kind`: "build" or "synth" (names the record). `owned_names`: every top-level name (folders
  // with a trailing '/') a run of this kind may write. Throws InputError naming the folder when
  // it cannot be created or written, is locked by another run, holds a folder where an output
  // file goes (or the reverse), or holds a symbolic link where stillmap keeps its own files.
  OutputSet(std::string dir, std::string kind, std::vector<std::string> owned_names);
  ~OutputSet();
  OutputSet(const OutputSet&) = delete;
  OutputSet& operator=(const OutputSet&) = delete;

  // The staging path of `name` (a path relative to the folder; parent folders are created).
  std::string TemporaryPath(const std::string& name);
  // The final path of `name` inside the folder.
  std::string FinalPath(const std::string& name) const;
  // The staging folder (files written there by other means are committed too).
  const std::string& staging_dir() const { return staging_; }
  // The files Commit() will rename aside: those staged so far plus `also_staged` (names still to
  // be written) that exist in the folder but are not in the last run's record.
  std::vector<SetAside> PlanSetAside(const std::vector<std::string>& also_staged = {}) const;
  // One warning per file PlanSetAside(also_staged) names: it was not written by stillmap and is
  // kept beside, renamed.
  std::vector<std::string> SetAsideWarnings(const std::vector<std::string>& also_staged) const;
  // Swaps the staged set in. Throws std::runtime_error when the journal cannot be written (the
  // earlier outputs are then unchanged) or a rename fails (the next run completes the swap).
  void Commit();
  // Non-empty when the constructor completed an interrupted earlier run's swap: what it did.
  const std::string& recovery_note() const { return recovery_note_; }
  // Entries of the folder that no run of this kind wrote: top-level names that are not outputs,
  // and files inside the output folders (renders/ ...) that are not in the record, sorted. They
  // are never deleted.
  std::vector<std::string> ForeignNames() const;

  // Whether `filename` (inside an output folder) is one of stillmap's own hidden entries.
  static bool IsInternalName(const std::string& filename);

 private:
  void Release();  // unlocks; removes the folder when this run created it and committed nothing
  std::vector<std::string> StagedNames() const;

  std::string dir_;
  std::string kind_;
  std::vector<std::string> owned_names_;
  std::vector<std::string> record_;  // what the last committed run wrote, sorted
  std::string staging_;
  std::string recovery_note_;
  int lock_fd_ = -1;
  bool created_dir_ = false;
  bool committed_ = false;
};

}  // namespace stillmap
