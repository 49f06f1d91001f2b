// What a mesh file must pass before Assimp reads it. Assimp 5.2 trusts the counts a file
// declares: it allocates for them up front and, for binary STL, checks them with 32-bit
// arithmetic that wraps, so a 100-byte file declaring 10^8 faces makes it allocate
// gigabytes or read past the end of its buffer (found by fuzz/mesh_fuzzer). Its PLY parser
// also loops forever on some malformed headers. penumbra therefore reads the header of
// PLY, OFF and binary STL files itself and refuses a file whose declared counts cannot fit
// in the bytes it holds. OBJ declares no counts; glTF/GLB are checked by Assimp's own
// accessor and buffer bounds.
#pragma once

#include <filesystem>

namespace penumbra {

// Throws Error naming the file (and the header line or count) when the file's header is
// malformed or declares more elements than its size allows. Files of other formats pass.
void check_mesh_file_header(const std::filesystem::path& path);

}  // namespace penumbra
