#pragma once
// The simulation file (.psim, issue 16): everything a scene precomputes from its sources — the
// prepared mesh (surface, normals, edges, regions, lumped areas, ring tables, octree; for a tet
// mesh the tets, tissue attributes, tet edges, the boundary faces with their owning tets and the
// surface-to-model map) and the model's precomputation where its kind stores one
// (ModelKind::save/load, engine/models/model.hpp) — in one versioned, checksummed binary file,
// so that a scene starts from it instead of regenerating and re-factorising.
//
// Layout (little-endian; docs/FORMATS.md "Simulation files (.psim)"):
//   header, 128 bytes:
//     0   char[8]   magic "PALPSIM\0"
//     8   u32       format version (kSceneFileVersion)
//     12  u32       header size (128)
//     16  u64       payload size (bytes)
//     24  u8[32]    checksum of the payload (256-bit, scene_file.cpp payload_checksum)
//     56  u8[32]    SHA-256 of the sources list (the fingerprint of what the scene is built from)
//     88  char[32]  palplab version "VERSION+COMMIT", NUL padded
//     120 u8[8]     first 8 bytes of the SHA-256 of header bytes 0..119
//   payload: sections {u32 tag, u64 length, bytes}: "SRCS" (the prototype path and each source
//   file with its SHA-256), "MKEY" (the mesh source's cache key, MeshSource::key), "MESH" (the
//   prepared mesh with its ring tables), "FIDX" (the contact tracker's face index: vertex-face
//   and edge-face tables, face boxes, the face hierarchy), "MODL" (model kind and its blob).
//
// Every check fails with a palplab::InputError naming the file and what is wrong (exit 2):
// not a .psim, wrong format version, built by another palplab build, corrupted header or
// payload (checksums), truncated or over-long, stale (a source changed since it was built).
#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "engine/haptics/scene_config.hpp"

namespace palplab::engine {

struct SceneMesh;

// Version 2: the MKEY section (the mesh's cache key) and the needle model's precomputation.
// Version 3: the mass-spring model's linear exterior factorisation (engine/solvers/far_field.hpp).
// Version 4: the FIDX section, the contact tracker's face index (engine/haptics/contact.hpp).
// Version 5: the payload checksum's eight-lane accumulation (scene_file.cpp payload_checksum).
// Version 6: FIDX ends with the surface's closedness (FaceIndex::closed).
inline constexpr std::uint32_t kSceneFileVersion = 6;
inline constexpr std::size_t kSceneFileHeaderBytes = 128;

// One source a scene is built from: the prototype file, a mesh file, the materials table.
struct SceneSource {
  std::string role;  // "prototype" | "mesh" | "materials"
  std::string path;  // absolute path ("<built-in>" for the compiled-in materials table)
  std::array<std::uint8_t, 32> sha256{};
};

// The sources of cfg with their current digests (cfg.source is the prototype file; it must be
// set). Throws InputError if a source file cannot be read.
std::vector<SceneSource> scene_sources(const SceneConfig& cfg);

// "VERSION+COMMIT" of this build, as stored in the header.
std::string scene_file_tool_version();

struct SceneFileInfo {
  std::uint32_t format_version = 0;
  std::string tool_version;
  std::uint64_t bytes = 0;  // whole file
  std::string prototype;    // the prototype file it was built from (absolute)
  std::vector<SceneSource> sources;
  std::string model_kind;
  bool model_blob = false;  // the model's precomputation is stored (not only the mesh)
};

// Builds (or takes from the process cache) everything cfg precomputes and writes it to `out`.
// cfg.source must name the prototype file. Throws InputError for an unwritable path.
SceneFileInfo write_scene_file(const std::string& out, const SceneConfig& cfg);

// Reads and verifies a .psim file (header, checksums, version; NOT the sources: see
// load_scene_file) and returns its contents. Throws InputError for every defect.
struct SceneFileData {
  SceneFileInfo info;
  std::shared_ptr<const SceneMesh> mesh;
  std::string mesh_key;    // MeshSource::key() of the mesh it was built from
  std::string model_blob;  // empty = none stored
};
SceneFileData read_scene_file(const std::string& path);

// Reads and verifies `path`, loads the configuration of the prototype it was built from with
// `load_config` (prototypes::load_prototype), checks that no source changed since (stale → an
// InputError naming the changed file) and installs the stored precomputation in the process
// caches, so that every later make_scene of that configuration (a probe, a study's sessions, a
// viewer) starts from it. Returns the configuration.
SceneConfig load_scene_file(const std::string& path,
                            const std::function<SceneConfig(const std::string&)>& load_config);

// The payload checksum (header offset 24): `best` is what the reader uses, the fastest path this
// CPU runs; the others (exposed for tests) must give the same bytes. Throws std::logic_error for
// a path this build or CPU does not have.
enum class ChecksumPath { best, avx2, sse2, portable };
std::array<std::uint8_t, 32> psim_payload_checksum(const void* p, std::size_t n,
                                                   ChecksumPath path = ChecksumPath::best);
bool psim_checksum_has_avx2();

}  // namespace palplab::engine
