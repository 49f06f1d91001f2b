// The near field's length (near_field_shared.h), shared by coherent-rt, mlsm and mtsm: where an
// occluder's penumbra narrows below the width the method's structure resolves.
#include <gtest/gtest.h>

#include <cmath>

#include "penumbra/shadow/near_field_shared.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

using shader::near_field_length;
using shader::near_field_light_width;

// An occluder at the returned distance d from the receiver, on a segment of length D to a light
// of width L, casts a penumbra L d / (D - d) wide at the receiver (similar triangles): exactly the
// resolved width. Nearer occluders cast narrower ones, farther ones wider.
TEST(NearField, EndsWhereAnOccludersPenumbraIsAsWideAsTheStructureResolves) {
  for (float light : {0.1f, 1.5f, 5.76f})
    for (float segment : {1.0f, 3.4f, 57.0f})
      for (float resolved : {0.001f, 0.05f, 0.6f}) {
        const float d = near_field_length(resolved, segment, light);
        ASSERT_GT(d, 0.0f);
        ASSERT_LT(d, segment);
        EXPECT_NEAR(light * d / (segment - d), resolved, 1e-4f * resolved + 1e-6f)
            << "L " << light << " D " << segment << " w " << resolved;
        const float nearer = 0.5f * d, farther = 0.5f * (d + segment);
        EXPECT_LT(light * nearer / (segment - nearer), resolved);
        EXPECT_GT(light * farther / (segment - farther), resolved);
      }
}

TEST(NearField, NoneWithoutAResolvedWidthAndTheWholeSegmentForAPointLight) {
  EXPECT_EQ(near_field_length(0.0f, 3.0f, 1.5f), 0.0f);  // near_field=0: the structure answers alone
  EXPECT_EQ(near_field_length(0.1f, 0.0f, 1.5f), 0.0f);
  EXPECT_EQ(near_field_length(0.1f, 3.0f, 0.0f), 3.0f);  // every penumbra is narrower than any width
  // A larger light widens every penumbra: the near field shortens; a longer segment lengthens it.
  EXPECT_LT(near_field_length(0.05f, 3.0f, 2.0f), near_field_length(0.05f, 3.0f, 1.0f));
  EXPECT_GT(near_field_length(0.05f, 6.0f, 1.0f), near_field_length(0.05f, 3.0f, 1.0f));
}

TEST(NearField, TheLightsWidthIsTheSideOfTheSquareOfItsArea) {
  EXPECT_FLOAT_EQ(near_field_light_width(1.5f * 1.5f), 1.5f);
  EXPECT_FLOAT_EQ(near_field_light_width(4.0f * 1.0f), 2.0f);
  EXPECT_EQ(near_field_light_width(0.0f), 0.0f);
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
