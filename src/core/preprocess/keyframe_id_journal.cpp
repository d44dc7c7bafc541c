#include "ccir_mapping/core/preprocess/keyframe_id_journal.h"

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <stdexcept>

namespace ccir_mapping::core::preprocess {

namespace {

constexpr const char* kHeader = "# ccir_mapping keyframe ids: every id below the next line's";

/// The reservation a journal file holds.
KeyframeId readCeiling(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read " + path);
  std::string header, number;
  std::getline(in, header);
  std::getline(in, number);
  if (header != kHeader || number.empty() || number.size() > 19 ||
      number.find_first_not_of("0123456789") != std::string::npos) {
    throw std::runtime_error(path + " is not a keyframe id journal (delete it to start from 0)");
  }
  const KeyframeId ceiling = std::stoull(number);
  // Team graph files keep the robot in a vertex id's top 8 bits (backend/g2o_io.h).
  if (ceiling >= (KeyframeId{1} << 56) - KeyframeIdJournal::kBlock) {
    throw std::runtime_error(path + " reserves ids beyond 2^56 (delete it to start from 0)");
  }
  return ceiling;
}

}  // namespace

KeyframeIdJournal::KeyframeIdJournal(const std::string& dir, bool resume)
    : path_(dir + "/" + kFileName) {
  std::error_code error;
  std::filesystem::create_directories(dir, error);
  if (error) throw std::runtime_error("cannot create " + dir + ": " + error.message());
  if (resume && std::filesystem::exists(path_)) {
    first_ = readCeiling(path_);
    resumed_ = true;
  } else if (std::filesystem::exists(path_)) {  // a new mission: the last one's kept beside
    std::filesystem::rename(path_, path_ + ".previous", error);
    if (error) throw std::runtime_error("cannot write " + path_ + ": " + error.message());
  }
  reserve(first_ + kBlock);
}

void KeyframeIdJournal::use(KeyframeId id) {
  if (id >= ceiling_) reserve(id + kBlock);
}

void KeyframeIdJournal::reserve(KeyframeId ceiling) {
  // Written aside, flushed to the disk and renamed over the journal: a crash (or power loss)
  // at any point leaves the old reservation or the new one, never a torn file.
  const std::string aside = path_ + ".new";
  std::FILE* file = std::fopen(aside.c_str(), "w");
  if (!file) throw std::runtime_error("cannot write " + aside);
  const bool written =
      std::fprintf(file, "%s\n%llu\n", kHeader, static_cast<unsigned long long>(ceiling)) > 0 &&
      std::fflush(file) == 0 && ::fsync(fileno(file)) == 0;
  if (std::fclose(file) != 0 || !written || std::rename(aside.c_str(), path_.c_str()) != 0) {
    throw std::runtime_error("cannot write " + path_);
  }
  ceiling_ = ceiling;
}

}  // namespace ccir_mapping::core::preprocess
