#include <gtest/gtest.h>

#include "ccir_mapping/core/preprocess/scan_gap_counter.h"

namespace ccir_mapping::core::preprocess {
namespace {

constexpr Stamp kPeriod = 100'000'000;  // a VLP-16 at 10 Hz

TEST(ScanGapCounter, RegularScansMissNothing) {
  ScanGapCounter gaps;
  for (int i = 0; i < 50; ++i) EXPECT_EQ(gaps.add(1'000'000'000 + i * kPeriod), 0U);
  EXPECT_EQ(gaps.missed(), 0U);
  EXPECT_EQ(gaps.period(), kPeriod);
}

TEST(ScanGapCounter, CountsTheScansOfEachGap) {
  ScanGapCounter gaps;
  Stamp t = 0;
  for (int i = 0; i < 5; ++i) EXPECT_EQ(gaps.add(t += kPeriod), 0U);
  EXPECT_EQ(gaps.add(t += 4 * kPeriod), 3U);  // three scans lost in between
  EXPECT_EQ(gaps.add(t += kPeriod), 0U);
  EXPECT_EQ(gaps.add(t += 2 * kPeriod), 1U);
  EXPECT_EQ(gaps.missed(), 4U);
}

TEST(ScanGapCounter, JitterIsNoGap) {
  ScanGapCounter gaps;
  Stamp t = 0;
  for (int i = 0; i < 40; ++i) {
    // Late by up to a fifth of a period, then early by as much.
    t += kPeriod + (i % 2 ? -1 : 1) * kPeriod * (i % 3) / 10;
    EXPECT_EQ(gaps.add(t), 0U) << i;
  }
  EXPECT_EQ(gaps.missed(), 0U);
}

TEST(ScanGapCounter, LearnsThePeriodDespiteLosses) {
  ScanGapCounter gaps;
  Stamp t = 0;
  gaps.add(t);
  EXPECT_EQ(gaps.add(t += 3 * kPeriod), 0U);  // no period known yet: not counted
  for (int i = 0; i < 3; ++i) gaps.add(t += kPeriod);
  EXPECT_EQ(gaps.period(), kPeriod);
  // A third of the scans lost: still the true period.
  for (int i = 0; i < 10; ++i) {
    EXPECT_EQ(gaps.add(t += kPeriod), 0U);
    EXPECT_EQ(gaps.add(t += 2 * kPeriod), 1U);
  }
  EXPECT_EQ(gaps.period(), kPeriod);
  EXPECT_EQ(gaps.missed(), 10U);
}

TEST(ScanGapCounter, StampsThatDoNotIncreaseCountNothing) {
  ScanGapCounter gaps;
  gaps.add(kPeriod);
  gaps.add(2 * kPeriod);
  EXPECT_EQ(gaps.add(2 * kPeriod), 0U);
  EXPECT_EQ(gaps.add(kPeriod), 0U);
  EXPECT_EQ(gaps.add(3 * kPeriod), 0U);
  EXPECT_EQ(gaps.missed(), 0U);
}

}  // namespace
}  // namespace ccir_mapping::core::preprocess
