#include "penumbra/gpu/scan.h"

#include "penumbra/gpu/scan_shared.h"

namespace penumbra::gpu {

void exclusive_scan(CommandList& commands, uint64_t values, uint32_t count) {
  shader::ExclusiveScanParams p{};
  p.values = values;
  p.count = count;
  // 256 threads: the kernel's one workgroup (its local size).
  commands.dispatch("scan_exclusive_one_group", 256, p);
}

}  // namespace penumbra::gpu
