// Error by object: a method's V error over the pixels that show some of the scene's objects
// (`compare --objects ground,'*.leaves'`), so that a comparison says where its error lives — on
// a wide scene, the ground's large penumbrae or the leaves a crown shadows from a few
// centimetres away (docs/compare.md, "Error by object"). A group is a shell-style pattern
// (fnmatch(3)) over object names (SceneObject::name: "ground", "forest.tree3.leaves"); its
// pixels are those whose first camera ray (camera ray index 0) hits an object it matches, from
// the camera pass every method's render makes (same scene, same seed: the same hits).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "penumbra/core/image.h"
#include "penumbra/eval/metrics.h"

namespace penumbra {

struct Scene;

struct ObjectGroup {
  std::string pattern;  // as given
  size_t objects = 0;   // scene objects it matches
  size_t pixels = 0;    // pixels whose first camera ray hits one of them
  Image mask;           // one channel: 1 on those pixels, 0 elsewhere (not in results.json)
};

// Which objects each pattern matches (per pattern, a flag per scene object). Throws Error naming
// the pattern when it is empty or matches no object's name (the message lists the scene's object
// names, the first few of them): a caller can check the patterns before it renders anything.
std::vector<std::vector<uint8_t>> match_object_patterns(const Scene& scene, const std::vector<std::string>& patterns);

// One group per pattern, in order (match_object_patterns' checks, then one camera pass). Throws Error naming the pattern when it is empty or matches
// no object's name (the message lists the scene's object names, the first few of them). A
// pattern that matches objects no pixel shows is a group of 0 pixels.
std::vector<ObjectGroup> object_groups(const Scene& scene, const std::vector<std::string>& patterns, uint64_t seed);

// V error of `test` against `reference` over each group's pixels, in the groups' order; a
// group of 0 pixels gets NaN errors (and pixels 0).
std::vector<ErrorStats> object_errors(const Image& test, const Image& reference, const std::vector<ObjectGroup>& groups);

}  // namespace penumbra
