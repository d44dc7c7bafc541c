// Keeps a robot's keyframe ids unique across restarts of its pipeline. Teammates know a
// keyframe by (robot, id) alone: a process that numbered from 0 again after a crash would have
// its new scans taken for old ones. Ids are reserved in blocks in a small file, each block
// written before any of its ids is handed out, so a process killed at any moment leaves a file
// naming an id above every one it used; a resumed process continues from there.
#pragma once

#include <string>

#include "ccir_mapping/core/common/types.h"

namespace ccir_mapping::core::preprocess {

class KeyframeIdJournal {
 public:
  /// Ids reserved per write: one small write per this many keyframes.
  static constexpr KeyframeId kBlock = 1000;
  static constexpr const char* kFileName = "keyframe_ids";

  /// The journal DIR/keyframe_ids (DIR created). With `resume`, ids continue above those the
  /// file reserved (from 0 when there is no file: nothing to resume); without, from 0, the last
  /// mission's file kept beside as keyframe_ids.previous. Either way the first block is
  /// reserved at once. Throws std::runtime_error naming the file when it
  /// cannot be read, is not a journal, or cannot be written.
  KeyframeIdJournal(const std::string& dir, bool resume);

  /// The first id this process may hand out.
  KeyframeId first() const { return first_; }
  /// Whether a journal was found and continued.
  bool resumed() const { return resumed_; }
  const std::string& path() const { return path_; }

  /// Call before handing out `id` (ids increasing): reserves the next block when `id` reaches
  /// the reservation. Throws std::runtime_error naming the file when it cannot be written.
  void use(KeyframeId id);

 private:
  void reserve(KeyframeId ceiling);

  std::string path_;
  KeyframeId first_ = 0;
  KeyframeId ceiling_ = 0;  // ids below it are reserved in the file
  bool resumed_ = false;
};

}  // namespace ccir_mapping::core::preprocess
