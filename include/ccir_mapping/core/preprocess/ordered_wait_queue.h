// Holds items (scans) in arrival order until what places them (odometry, tf) has arrived.
#pragma once

#include <cstddef>
#include <deque>
#include <optional>
#include <utility>

namespace ccir_mapping::core::preprocess {

/// Items are released strictly in arrival order, which callers keep equal to stamp order. What
/// makes an item ready (odometry or transforms) arrives in time order too, so an item that is
/// not ready while a later one is never will be: it is dropped rather than blocking the rest.
template <class T>
class OrderedWaitQueue {
 public:
  explicit OrderedWaitQueue(std::size_t capacity) : capacity_(capacity < 1 ? 1 : capacity) {}

  /// Adds an item; when the queue was full, returns the oldest item, pushed out.
  std::optional<T> push(T item) {
    items_.push_back(std::move(item));
    if (items_.size() <= capacity_) return std::nullopt;
    T oldest = std::move(items_.front());
    items_.pop_front();
    return oldest;
  }

  /// Calls release(item) for each ready item from the front, and drop(item) for a front item
  /// that a later ready item overtakes; stops at the first item that must wait.
  template <class Ready, class Release, class Drop>
  void drain(Ready ready, Release release, Drop drop) {
    while (!items_.empty()) {
      T front = std::move(items_.front());
      items_.pop_front();
      if (ready(front)) {
        release(front);
        continue;
      }
      bool overtaken = false;
      for (const T& later : items_) {
        if ((overtaken = ready(later))) break;
      }
      if (!overtaken) {
        items_.push_front(std::move(front));
        return;
      }
      drop(front);
    }
  }

  std::size_t size() const { return items_.size(); }
  bool empty() const { return items_.empty(); }

 private:
  std::size_t capacity_;
  std::deque<T> items_;
};

}  // namespace ccir_mapping::core::preprocess
