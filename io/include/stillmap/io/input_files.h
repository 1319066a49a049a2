// Checks of input paths before anything opens them, so that a folder, a FIFO or a symbolic link
// loop where a file belongs gets a sentence naming it instead of a block, a crash or a library's
// internal message.
#pragma once

#include <string>
#include <system_error>

namespace stillmap {

// Throws InputError naming `path` and `what` it should be unless it is a regular file (or a
// symbolic link to one) that can be read: not missing, not a folder, a FIFO or a device, not a
// symbolic link loop.
void CheckInputFile(const std::string& path, const std::string& what);

// For a sequence path that is not a bag: throws InputError saying what is there instead of a
// TUM-layout folder (nothing, an empty or unreadable file, a file that is not a bag, a FIFO or
// device, an empty folder, a folder without rgb.txt); returns for a folder holding rgb.txt.
void CheckSequenceFolder(const std::string& path);

// Why a stat of a path failed, in the user's words ("a symbolic link loop: ...", "permission
// denied ..."), not the library's.
std::string StatProblem(const std::error_code& error);

// Whether anything is at `path`, a broken or looping symbolic link included (so that the reader
// then names what is wrong with it). Never throws.
bool PathExists(const std::string& path);

}  // namespace stillmap
