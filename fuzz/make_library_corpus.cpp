// Writes the seed corpus of library_image_fuzz: small valid libraries made by the store's own
// writer (io/library_writer.hpp), one per combination of compression (none, lz4, deflate) and
// checksum (on, off), plus one with a per-clip provenance (pops, contacts) and a library-wide
// one. Run by CMake at build time (fuzz/CMakeLists.txt), so no binary seed is checked in.
// Usage: make_library_corpus DIR. Deterministic: the same bytes on every run (a fixed
// `created` time), so CI's smoke run (seed 1) runs the same inputs every time.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "io/library_store.hpp"

namespace {

using namespace mocap;
using namespace mocap::io;

std::shared_ptr<const Skeleton> make_skeleton(int joints) {
  auto s = std::make_shared<Skeleton>();
  for (int j = 0; j < joints; ++j) {
    s->joint_names.push_back(j == 0 ? "Hips" : "J" + std::to_string(j));
    s->parents.push_back(j - 1);
    s->offsets.push_back({0.0, 1.0 + j, 0.5});
    if (j == 0)
      s->channels.push_back({Channel::Xposition, Channel::Yposition, Channel::Zposition,
                             Channel::Zrotation, Channel::Xrotation, Channel::Yrotation});
    else
      s->channels.push_back({Channel::Zrotation, Channel::Xrotation, Channel::Yrotation});
    s->end_sites.push_back(j == joints - 1 ? std::optional<Vec3>(Vec3{0, 1, 0}) : std::nullopt);
  }
  return s;
}

// A smooth clip: rotations about z, unit quaternions; the root moves along x.
Clip make_clip(int joints, int frames) {
  Clip clip;
  clip.skeleton = make_skeleton(joints);
  clip.frame_time = 1.0 / 120;
  clip.frames = frames;
  clip.source = "seed.bvh";
  for (int t = 0; t < frames; ++t)
    for (int j = 0; j < joints; ++j) {
      const double a = 0.05 * t + 0.1 * j;
      for (float v : {float(std::cos(a / 2)), 0.0f, 0.0f, float(std::sin(a / 2))})
        clip.rotations.push_back(v);
      for (float v : {j == 0 ? 0.1f * float(t) : 0.0f, float(1.0 + j), 0.5f})
        clip.translations.push_back(v);
    }
  return clip;
}

bool write(const std::filesystem::path& path, Compression compression, bool checksum,
           bool provenance) {
  std::string error;
  auto writer = LibraryWriter::create(path, compression, &error, checksum);
  bool ok = writer != nullptr;
  Clip first = make_clip(3, 4);
  if (provenance) {
    first.provenance.method = "bof";
    first.provenance.parameters_json = R"({"sigma_t":1.0})";
    first.provenance.noise_sigma = 0.01;
    first.provenance.pop_stage = true;
    first.provenance.pops_repaired = true;
    first.provenance.pops = {1, 2};
    first.provenance.feet = true;
    first.provenance.contacts = {2, 0, 3};
  }
  ok = ok && writer->write_clip("a/c0", first, &error);
  // Small clips (one chunk each) keep the seeds a few KB, so mutations hit headers, not data.
  ok = ok && writer->write_clip("a/b/c1", make_clip(2, 3), &error);
  ok = ok && writer->write_clip("c2", make_clip(3, 1), &error);
  if (provenance)
    ok = ok && writer->write_provenance(
                   {"bof", R"({"sigma_t":1.0})", "seed", "in.h5", "2026-01-01T00:00:00Z"}, &error);
  ok = ok && writer->close(&error);
  if (!ok) std::fprintf(stderr, "make_library_corpus: %s\n", error.c_str());
  return ok;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: make_library_corpus DIR\n");
    return 2;
  }
  const std::filesystem::path dir = argv[1];
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) {
    std::fprintf(stderr, "make_library_corpus: %s: %s\n", dir.c_str(), ec.message().c_str());
    return 2;
  }
  bool ok = true;
  for (Compression compression : {Compression::none, Compression::lz4, Compression::deflate}) {
    if (!compression_available(compression)) {
      std::fprintf(stderr, "make_library_corpus: %s unavailable, no seed for it: %s\n",
                   std::string(to_string(compression)).c_str(),
                   compression_unavailable_reason(compression).c_str());
      continue;
    }
    for (bool checksum : {true, false}) {
      const std::string name =
          std::string(to_string(compression)) + (checksum ? "-checksum" : "-plain") + ".h5";
      ok = write(dir / name, compression, checksum, false) && ok;
    }
  }
  ok = write(dir / "none-provenance.h5", Compression::none, true, true) && ok;
  return ok ? 0 : 1;
}
