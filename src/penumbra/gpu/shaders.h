// The compute kernels compiled at build time (glslc, Vulkan 1.3) and embedded in the program
// as SPIR-V words (cmake/embed_spirv.cmake writes the table). A kernel's name is its .comp
// file's name; Device::kernel builds a pipeline from the module of that name.
#pragma once

#include <cstdint>
#include <span>
#include <string_view>

namespace penumbra::gpu {

struct SpirvModule {
  std::string_view name;
  std::span<const uint32_t> words;
};

// Every embedded module, sorted by name.
std::span<const SpirvModule> spirv_modules();
// The module of that name, or null.
const SpirvModule* find_spirv(std::string_view name);

}  // namespace penumbra::gpu
