#pragma once
// Turning the SRC... arguments of a command into the list of BVH files to read, each with the
// relative path it keeps in the output (folders are walked recursively).
#include <filesystem>
#include <string>
#include <vector>

namespace mocap::engine {

struct SourceFile {
  std::filesystem::path path;  // as found on disk
  std::string relative;        // output-relative path with '/', e.g. "02/02_01.bvh"
};

struct SourceList {
  std::vector<SourceFile> files;    // sorted by relative path, duplicates removed
  std::vector<std::string> errors;  // arguments that are neither a .bvh file nor a folder
};

// A file argument keeps its own name; a folder argument contributes every *.bvh below it
// (case-insensitive extension) relative to the folder. Symlinked folders are not followed.
// The same file reached twice counts once; two different files that would keep the same
// relative path are an error (one would be lost). With an `output_folder` (clean's -o): a file
// it would overwrite (output_folder / relative is the file itself) is an error, and nothing below
// it is collected, so a run does not read what an earlier run wrote.
SourceList collect_bvh_sources(const std::vector<std::string>& arguments,
                               const std::filesystem::path& output_folder = {});

}  // namespace mocap::engine
