// What a mesh file must pass before Assimp reads it. Assimp 5.2 trusts the counts a file
// declares: it allocates for them up front and, for binary STL, checks them with 32-bit
// arithmetic that wraps, so a 100-byte file declaring 10^8 faces makes it allocate
// gigabytes or read past the end of its buffer (found by fuzz/mesh_fuzzer). Its PLY parser
// also loops forever on some malformed headers. penumbra therefore reads the header of
// PLY, OFF and binary STL files itself and refuses a file whose declared counts cannot fit
// in the bytes it holds. OBJ declares no counts, but Assimp's face parser reads past its
// buffer on malformed vertex references, so their syntax is checked (in every text file:
// Assimp reads any file that starts with OBJ keywords as OBJ). Its glTF reader copies
// accessors without checking their buffer views' bounds, so glTF and GLB files have their
// accessors, views and buffers checked against each other.
#pragma once

#include <filesystem>

namespace penumbra {

// Throws Error naming the file (and the header line or count) when the file's header is
// malformed or declares more elements than its size allows, (OBJ) an element lists a
// malformed vertex reference, or (glTF) an accessor reads outside its buffer view, a view
// outside its buffer, or a buffer holds fewer bytes than it declares. Other files pass.
void check_mesh_file_header(const std::filesystem::path& path);

}  // namespace penumbra
