#!/usr/bin/env bash
# The whole test suite, as CI runs it (README command 2, .ci/run):
#   1. scripts/setup.sh --with-test-tools --all: the packages, the test tools, the Release build
#      of everything in build/ (the tool, the Python module, the tests and the benchmarks), then
#      its test suite;
#   2. a second build in build-san/ with clang: AddressSanitizer and UndefinedBehaviorSanitizer
#      over everything (-O1) and the libFuzzer targets (fuzz/), then the same test suite under
#      the sanitizers plus a 60-s run of each fuzzer (CTest label `fuzz`).
# docs/reliability.md says what each part covers. Stops at the first failure.
# The GPU tests run on whatever Vulkan device there is (in CI: Mesa's lavapipe, on the CPU), in the
# Release stage under the Khronos validation layers (any message fails a test), and fail rather
# than skip when there is none (docs/gpu.md, "Tests").
set -euo pipefail
cd "$(dirname "$0")/.."
export PENUMBRA_GPU_VALIDATION=1 PENUMBRA_REQUIRE_GPU=1
# Every process of the build and the tests with glibc's heap on 2 MiB pages, as the command line
# puts itself (src/penumbra/core/huge_pages.h): page faults were a fifth of a wide render's time.
export GLIBC_TUNABLES="${GLIBC_TUNABLES:+$GLIBC_TUNABLES:}glibc.malloc.hugetlb=1"
scripts/setup.sh --with-test-tools --all build
ctest --test-dir build --output-on-failure -j 2
# In groups of files, as the Release build (PENUMBRA_UNITY_BUILD): 11.4 min on 2 cores against
# 15.9 file by file (2026-12-06). A library file that compiles only thanks to what its group
# includes before it is caught by CMake's default build (one file at a time), not here.
CXX=clang++-14 cmake -S . -B build-san -DCMAKE_BUILD_TYPE=Release -DPENUMBRA_SANITIZE=ON -DPENUMBRA_FUZZ=ON \
  -DPENUMBRA_BUILD_BENCH=OFF -DPENUMBRA_UNITY_BUILD=ON >/dev/null
cmake --build build-san -j "$(nproc)"
# The Vulkan loader and Mesa's driver (uninstrumented) keep allocations to the end of the process:
# leak reports from inside them alone are suppressed (scripts/lsan-vulkan.supp), and silently: the
# summary of used suppressions would add lines to the one-line errors the tests check.
# Left out under the sanitizers (the Release stage above runs them): the eight tests that render
# every method, or one scene at many settings, end to end: 1,600 of the sanitizer suite's
# 3,400 s on 2 cores (2026-11-28), 5-12 times their Release time; and six that check a property
# of a picture at a size that takes 40-62 s each here (8-10 times their Release time: the two
# thread counts of every method, coherent-rt's sampling, tiles, alpha and regression bound, the
# GPU's light-space partitions). Every method's host code still runs under the sanitizers
# through its own tests (coherent-rt's through five others; docs/reliability.md).
san_skip='^(Renderer\.EveryMethodsFramesAfterObjectsMoveEqualFreshRenders'
san_skip+='|Renderer\.EveryMethodsReusedFramesEqualFreshRendersAlongACameraWalkAndALightMove'
san_skip+='|TexturedLight\.TwoColourLightGivesTheClosedFormColouredPenumbra'
san_skip+='|GpuFrame\.TheUpFrontEstimateCoversWhatARenderHolds|Tiles\.EmptyOrWholeImageCropIsNoCrop'
san_skip+='|CliGpu\.CompareOnTheGpuRunsEveryMethod|Tiles\.EveryMethodsTilesReassembleIntoTheWholeFrame'
san_skip+='|ViewerOnGpu\.ASessionOnTheGpuRendersThereAndOffersItsMethods'
san_skip+='|Determinism\.EveryMethodGivesTheSameImageWithOneAndTwoThreads'
san_skip+='|CoherentRt\.CoherenceSamplingStaysCloseToTracingEveryCellAndTracesFewerRays'
san_skip+='|Tiles\.CoherentRtIsExactForTileAlignedCrops|LightPartitionsGpu\.PartitionsGiveTheCpuPictures'
san_skip+='|Methods/MethodRegression\.MeanErrorAgainstTheReferenceIsNoWorseThanMeasured/coherent_rt'
san_skip+='|Methods/EveryMethodRespectsAlpha\.CheckerboardMaskCastsTheCheckerboardInTriangles/coherent_rt'
# and seven more end-to-end renders at 8-15 times their Release time here (2026-12-06: 234 s of the
# stage's 1,856 s of test time): lam's and coherent-rt's pictures against the ground truth and
# across thread counts (their near field and traced points run here through their own tests),
# the light change and the map cache of the renderer and viewer, the bench suite at a small size.
san_skip+='|CoherentRt\.DepthImagesAgreeWithTheReferenceOnTheSameSamples|CoherentRt\.ResultsDoNotDependOnTheThreadCount'
san_skip+='|Methods/MethodRegression\.MeanErrorAgainstTheReferenceIsNoWorseThanMeasured/lam'
san_skip+='|Methods/EveryMethodRespectsAlpha\.CheckerboardMaskCastsTheCheckerboardInTriangles/lam'
san_skip+='|Renderer\.SetLightsEqualsAFreshRendererAndKeepsUnchangedLights|Viewer\.MapCacheKeepsLamsMapsBetweenSessions'
san_skip+='|CliGpu\.TheGpuBenchSuiteRunsAtASmallSize'
# and `penumbra devices --compile`, which builds every kernel's pipeline in Mesa's compiler (not
# instrumented: 21 s here, 5 in Release; every GPU test above builds the pipelines it uses).
san_skip+='|CliGpu\.DevicesCompileTimesEveryKernel'
# and every method at three scales and facing away on the GPU, and far from the origin against
# the CPU, end to end (41 s and 35 s in Release; each method's host code runs through its own GPU
# tests), and coherent-rt's three scales and three offsets on the CPU.
san_skip+='|GpuFrame\.EveryMethodsVIsTheSameInAnyUnitAndZeroWhereTheLightFacesAway|GpuFrame\.FarFromTheOriginEveryMethodDrawsTheCpusV'
san_skip+='|Methods/SceneUnits\.TheSameSceneAHundredTimesSmallerOrAHundredThousandTimesLargerHasTheSameV/coherent_rt'
san_skip+='|Methods/SceneUnits\.FarFromTheOriginEveryMethodIsAsCloseToTheGroundTruth/coherent_rt'
# and the ceiling at the light: coherent-rt's and lam's CPU renders (40 s and 22 s here, 4 and 6 in
# Release) and every changed method on both devices (24 s); and coherent-rt's light field and disk
# lights on the CPU against its geometry tracer (42 s and 30 s): the GPU tests of the same scenes
# (CoherentRtGpu.CastersBesideTheLight..., DiskAndSphereLights...) render the CPU's picture here
# too; so do the sphere lights' (a reference at 256 samples beside them).
san_skip+='|Methods/SceneUnits\.ACeilingFlushWithTheLightOrBehindItChangesNoV/(coherent_rt|lam)'
san_skip+='|GpuFrame\.ACeilingFlushWithTheLightBlocksNothingAsOnTheCpu'
san_skip+='|CoherentRt\.CastersBesideTheLightAreTracedInTheLightField|CoherentRt\.DiskLightsAreSampledOnTheirCellsAsRectLightsAre'
san_skip+='|CoherentRt\.SphereLightsAreSampledThroughTheirCentralDisk'
# and the bulb in a room (a sphere split into six faces, each its own maps): coherent-rt's, lam's
# and mtsm's CPU renders (8 s, 0.7 s and 1.2 s in Release; lam 22 s and mtsm 9 s here), and the
# GPU test that holds four methods against the CPU (14 s in Release): the split's host code runs
# here through the other methods' CPU renders.
san_skip+='|Methods/SceneUnits\.ABulbInARoomLightsTheCeilingAndTheWallsBehindItsDisk/(coherent_rt|lam|mtsm)'
san_skip+='|GpuFrame\.ABulbInARoomIsDrawnFaceByFaceAsOnTheCpu'
# and its objects moving around the bulb on the GPU (20 s in Release; the CPU's test of the same
# set_objects runs here).
san_skip+='|GpuFrame\.MovingObjectsSplitASphereLightAgainAsAFreshRender'
# and the two GPU tests of rays outside a capped or narrow map (16 s and 10 s here, 5 and 4 in
# Release): their CPU tests run here (Multilayer.RaysTheCappedMapDoesNotHoldAreTraced,
# MultiViewShadowMap.ReceiversBeyondAMapsWindowAreTraced), the kernels are not instrumented.
san_skip+='|MultilayerGpu\.RaysTheCappedMapDoesNotHoldAreTracedAsOnTheCpu|MultiViewGpu\.ReceiversBeyondAMapsWindowAreTracedAsOnTheCpu'
# and the GPU tests that render one method at each of its parameters against the CPU (the
# kernels are not instrumented; each method's host code runs here through its other GPU tests:
# its pictures, crops, buffers that grow, memory), with three more at 4-5 times their Release
# time (the partitions' one-map case, vsm's bunny on both devices, the GPU bench suite): 146 s of
# the stage's 1,517 s of test time (2026-12-06).
san_skip+='|[A-Za-z]+Gpu\.EveryParameterWorksAsOnTheCpu|LightPartitions\.NothingIsSplitWhereOneMapHoldsTheCasters'
san_skip+='|FilteredMomentsGpu\.BunnyGivesTheCpuPictures|CliGpu\.TheGpuBenchSuiteWithoutItsCpuSide)( +# GetParam.*)?$'
# The Khronos validation layers are the Release stage's check: here they would only check the
# same Vulkan calls again, at a quarter of each GPU test's time (they are not instrumented).
PENUMBRA_GPU_VALIDATION=0 LSAN_OPTIONS=suppressions=$PWD/scripts/lsan-vulkan.supp:print_suppressions=0 \
  ctest --test-dir build-san --output-on-failure -j 2 -E "$san_skip"
