// Outputs are written under temporary names and renamed when complete, so that a failed run never
// leaves a file that looks finished.
#pragma once

#include <string>
#include <vector>

namespace stillmap {

// "dir/name.ext" -> "dir/.name.ext.tmp" (hidden, and clearly not a finished output).
std::string TemporaryPathFor(const std::string& path);

// Renames `temporary` to `final_path`; throws std::runtime_error naming both on failure.
void CommitTemporary(const std::string& temporary, const std::string& final_path);

// Creates `dir` (and parents) when needed and checks that files can be created in it. Throws
// InputError naming the folder when it cannot be written.
void PrepareOutputFolder(const std::string& dir);

// A set of outputs written together: each file is first written to TemporaryPath(name); Commit()
// renames all of them; destroying the set without Commit() removes the temporaries.
class OutputSet {
 public:
  explicit OutputSet(std::string dir);
  ~OutputSet();
  OutputSet(const OutputSet&) = delete;
  OutputSet& operator=(const OutputSet&) = delete;

  // Registers `name` (a file name inside the folder) and returns the temporary path to write.
  std::string TemporaryPath(const std::string& name);
  // The final path of `name` inside the folder.
  std::string FinalPath(const std::string& name) const;
  // Renames every registered temporary to its final name.
  void Commit();

 private:
  std::string dir_;
  std::vector<std::string> names_;
  bool committed_ = false;
};

}  // namespace stillmap
