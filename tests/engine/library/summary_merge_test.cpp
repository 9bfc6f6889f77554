// The --json tallies of MPI ranks summed into one (engine/library/summary_merge.hpp).
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "engine/library/summary_merge.hpp"

namespace mocap::engine {
namespace {

using nlohmann::json;

json rank_summary(int pops, const std::string& joint, const std::string& clip, double sigma) {
  return {{"method", "auto"},
          {"pops",
           {{"mode", "auto"},
            {"samples", pops},
            {"repaired", pops},
            {"clips", 1},
            {"by_joint", {{joint, pops}}}}},
          {"garbage_joints",
           {{"joints", 1},
            {"clips", 1},
            {"handling", "kept as they came"},
            {"by_clip", json::array({{{"clip", clip}, {"joints", json::array()}}})}}},
          {"automatic",
           {{"clips", 1},
            {"methods", {{"nlpm", 1}}},
            {"noise_sigma", {{"min", sigma}, {"max", sigma}}},
            {"by_clip", json::array({{{"clip", clip}, {"noise_sigma", sigma}}})}}}};
}

TEST(SummaryMerge, SumsCountsJoinsListsAndWidensTheNoiseRange) {
  json total = rank_summary(3, "LeftToeBase", "a", 0.02);
  merge_tallies(total, rank_summary(2, "LeftToeBase", "b", 0.05));
  merge_tallies(total, rank_summary(4, "RightHand", "c", 0.01));
  EXPECT_EQ(total["pops"]["samples"], 9);
  EXPECT_EQ(total["pops"]["repaired"], 9);
  EXPECT_EQ(total["pops"]["clips"], 3);
  EXPECT_EQ(total["pops"]["by_joint"], json({{"LeftToeBase", 5}, {"RightHand", 4}}));
  EXPECT_EQ(total["pops"]["mode"], "auto");
  EXPECT_EQ(total["garbage_joints"]["joints"], 3);
  EXPECT_EQ(total["garbage_joints"]["by_clip"].size(), 3u);
  EXPECT_EQ(total["automatic"]["clips"], 3);
  EXPECT_EQ(total["automatic"]["methods"]["nlpm"], 3);
  EXPECT_EQ(total["automatic"]["noise_sigma"]["min"], 0.01);
  EXPECT_EQ(total["automatic"]["noise_sigma"]["max"], 0.05);
  EXPECT_EQ(total["automatic"]["by_clip"][2]["clip"], "c");
  EXPECT_EQ(total["method"], "auto");
}

TEST(SummaryMerge, StageSecondsAddUpOverTheRanks) {
  json total = {{"stages", {{"read", 1.5}, {"filter", 2.0}}}};
  merge_tallies(total, {{"stages", {{"read", 0.5}, {"filter", 1.0}, {"write", 0.25}}}});
  merge_tallies(total, json::object());  // a rank that ran nothing
  EXPECT_DOUBLE_EQ(total["stages"]["read"].get<double>(), 2.0);
  EXPECT_DOUBLE_EQ(total["stages"]["filter"].get<double>(), 3.0);
  EXPECT_DOUBLE_EQ(total["stages"]["write"].get<double>(), 0.25);
}

TEST(SummaryMerge, ARankWithoutClipsTakesTheOthersTallies) {
  json total = {{"method", "auto"}};  // rank 0 had no clips of its own
  merge_tallies(total, rank_summary(2, "RightHand", "b", 0.03));
  EXPECT_EQ(total["pops"]["samples"], 2);
  EXPECT_EQ(total["automatic"]["clips"], 1);
  json off = {{"pops", {{"mode", "off"}}}};
  merge_tallies(off, json{{"pops", {{"mode", "off"}}}});
  EXPECT_EQ(off, json({{"pops", {{"mode", "off"}}}}));
}

}  // namespace
}  // namespace mocap::engine
