// For tests of the methods that keep a GpuRasterizer of their own (inside a method, where a test
// cannot call GpuRasterizer::set_capacities_for_testing): while a RasterCapacitiesForTesting
// lives, every GpuRasterizer created starts with its capacities, so that the method's renders
// outgrow their buffers and must grow them and render again (never drop work, issue 29), and it
// counts those retries. One at a time; defined in gpu_rasterizer.cpp.
#pragma once

#include <cstdint>

namespace penumbra::gpu {

class RasterCapacitiesForTesting {
 public:
  RasterCapacitiesForTesting(uint32_t triangles, uint32_t items);
  ~RasterCapacitiesForTesting();
  RasterCapacitiesForTesting(const RasterCapacitiesForTesting&) = delete;
  RasterCapacitiesForTesting& operator=(const RasterCapacitiesForTesting&) = delete;

  // How many renders since this was made found their buffers too small and rendered again.
  int retries() const;
};

}  // namespace penumbra::gpu
