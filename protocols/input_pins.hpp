#pragma once
// Checksums that pin a run's inputs, so that `run --resume` refuses files that changed since the
// run started (the study file is pinned by its own SHA-256 in the study record).
#include <string>

namespace palplab::protocols {

// SHA-256 (hex) of a prototype file together with the mesh file(s) it names in mesh.file
// (resolved like the prototype loader does: relative to the prototype file; a TetGen base pins
// BASE.node, BASE.ele and BASE.names). For a prototype without mesh.file it equals the SHA-256
// of the file's text, so databases written before mesh pinning still resume. A file that cannot
// be read hashes as its name only (the loader reports the missing file itself).
std::string prototype_sha256(const std::string& prototype_path);

}  // namespace palplab::protocols
