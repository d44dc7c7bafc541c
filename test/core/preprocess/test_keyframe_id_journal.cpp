#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "ccir_mapping/core/preprocess/keyframe_id_journal.h"

namespace ccir_mapping::core::preprocess {
namespace {

/// A fresh folder per test.
std::string freshDir(const std::string& name) {
  const std::string dir =
      ::testing::TempDir() + "keyframe_id_journal_" + std::to_string(::getpid()) + "/" + name;
  std::filesystem::remove_all(dir);
  return dir;
}

TEST(KeyframeIdJournal, ANewMissionStartsAtZeroAndReservesAtOnce) {
  const std::string dir = freshDir("new");
  KeyframeIdJournal journal(dir, /*resume=*/false);
  EXPECT_EQ(journal.first(), 0u);
  EXPECT_FALSE(journal.resumed());
  // Killed before its first keyframe, a resumed successor still starts above the block.
  EXPECT_EQ(KeyframeIdJournal(dir, true).first(), KeyframeIdJournal::kBlock);
}

TEST(KeyframeIdJournal, AResumedRunContinuesAboveEveryIdAKilledRunUsed) {
  const std::string dir = freshDir("resume");
  KeyframeId last_used = 0;
  {
    KeyframeIdJournal journal(dir, false);
    for (KeyframeId id = 0; id < 2500; ++id) journal.use(last_used = id);
  }  // no shutdown step: a process killed now leaves the file as it is
  KeyframeIdJournal resumed(dir, true);
  EXPECT_TRUE(resumed.resumed());
  EXPECT_GT(resumed.first(), last_used);
  EXPECT_LE(resumed.first(), last_used + 1 + KeyframeIdJournal::kBlock);
  // And the next restart continues above the resumed run's ids, not the first run's.
  resumed.use(resumed.first() + 5000);
  EXPECT_GT(KeyframeIdJournal(dir, true).first(), resumed.first() + 5000);
}

TEST(KeyframeIdJournal, WithoutResumeANewMissionStartsAtZeroAgainAndKeepsTheLastOneBeside) {
  const std::string dir = freshDir("again");
  KeyframeIdJournal(dir, false).use(4000);
  EXPECT_EQ(KeyframeIdJournal(dir, false).first(), 0u);
  EXPECT_EQ(KeyframeIdJournal(dir, true).first(), KeyframeIdJournal::kBlock);
  // Renamed back, the mission before continues above its ids.
  std::filesystem::rename(dir + "/keyframe_ids.previous", dir + "/keyframe_ids");
  EXPECT_EQ(KeyframeIdJournal(dir, true).first(), 4000u + KeyframeIdJournal::kBlock);
}

TEST(KeyframeIdJournal, ResumingWithNothingSavedStartsAtZero) {
  KeyframeIdJournal journal(freshDir("nothing"), true);
  EXPECT_EQ(journal.first(), 0u);
  EXPECT_FALSE(journal.resumed());
}

TEST(KeyframeIdJournal, AFileThatIsNotAJournalIsRefusedByName) {
  const std::string dir = freshDir("garbage");
  std::filesystem::create_directories(dir);
  for (const char* content : {"", "hello\n12\n", "# ccir_mapping keyframe ids\n-3\n",
                              "# ccir_mapping keyframe ids: every id below the next line's\n12x\n",
                              "# ccir_mapping keyframe ids: every id below the next line's\n"
                              "99999999999999999\n"}) {
    std::ofstream(dir + "/keyframe_ids") << content;
    try {
      KeyframeIdJournal journal(dir, true);
      ADD_FAILURE() << "accepted: " << content;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(dir + "/keyframe_ids"), std::string::npos) << e.what();
    }
  }
  // A new mission does not read it: it starts over.
  EXPECT_EQ(KeyframeIdJournal(dir, false).first(), 0u);
}

TEST(KeyframeIdJournal, AFolderThatCannotBeWrittenIsAnError) {
  const std::string file = freshDir("blocked");
  std::filesystem::create_directories(std::filesystem::path(file).parent_path());
  std::ofstream(file) << "a file, not a folder";
  EXPECT_THROW(KeyframeIdJournal(file + "/robot_a", false), std::runtime_error);
}

}  // namespace
}  // namespace ccir_mapping::core::preprocess
