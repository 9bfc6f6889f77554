#pragma once
// Joining library files: the parts that separate batches, threads or processes wrote become one
// library file. Also the "master" of an unfinished run: a small file whose /clips are external
// links into the parts, valid HDF5 at every moment, that h5py and LibraryReader read as if the
// clips were inside.
#include <filesystem>
#include <string>
#include <vector>

#include "io/library_format.hpp"

namespace mocap::io {

// Copies every clip of every part (and the skeletons they use) into a new file at `output`,
// with the parts' stored chunks as they are (no recompression). Fails, naming the clip, when two
// parts hold the same clip path. `provenance` is written when its method is non-empty.
bool join_libraries(const std::vector<std::filesystem::path>& parts,
                    const std::filesystem::path& output, const Provenance& provenance,
                    std::string* error);

// Writes `output` as a library whose clips are external links into `parts` (paths stored
// relative to output's folder). Clip paths repeated across parts: the first part wins.
bool link_libraries(const std::vector<std::filesystem::path>& parts,
                    const std::filesystem::path& output, std::string* error);

// Adds links to the clips of `part` to an existing library of links (made by link_libraries);
// clip paths it already has are left alone.
bool add_library_links(const std::filesystem::path& part, const std::filesystem::path& output,
                       std::string* error);

}  // namespace mocap::io
