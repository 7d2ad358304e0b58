#pragma once

#include <map>
#include <memory>
#include <mutex>

namespace tac3d {

/// One immutable value per key for the whole process, while anyone holds it: several sensors of
/// one model share its matrices (tens of MB each) instead of each making its own. The cache keeps
/// only a weak reference, so a value is freed when its last holder lets it go, and made anew if
/// asked for again.
///
/// Thread-safe. The first caller for a key makes the value; other callers for the same key wait
/// for it and get the same object (one copy is made, never two), while callers for other keys
/// go on. If making throws, the exception reaches that caller only and the next waiter tries
/// again.
template <typename Key, typename Value>
class SharedCache {
 public:
  /// The value alive for `key`, or `make()`'s (a std::shared_ptr<const Value>), kept for the
  /// next callers while it lives.
  template <typename Make>
  std::shared_ptr<const Value> Get(const Key& key, Make&& make) {
    const std::shared_ptr<Slot> slot = FindOrAddSlot(key);
    const std::lock_guard<std::mutex> making(slot->mutex);
    if (std::shared_ptr<const Value> value = slot->value.lock()) return value;
    std::shared_ptr<const Value> value = make();
    slot->value = value;
    return value;
  }

 private:
  struct Slot {
    std::mutex mutex;  // held while the value is made
    std::weak_ptr<const Value> value;
  };

  // The key's slot; the slots of values freed meanwhile are dropped, unless a caller holds one
  // (it waits to make its value).
  std::shared_ptr<Slot> FindOrAddSlot(const Key& key) {
    const std::lock_guard<std::mutex> lock(mutex_);
    for (auto it = slots_.begin(); it != slots_.end();) {
      it = IsUnused(*it->second, it->second.use_count()) ? slots_.erase(it) : std::next(it);
    }
    std::shared_ptr<Slot>& slot = slots_[key];
    if (!slot) slot = std::make_shared<Slot>();
    return slot;
  }

  // Called with mutex_ held: a slot only the map holds stays so, as callers take theirs under
  // mutex_; its own lock orders the read of its value after the last write.
  static bool IsUnused(Slot& slot, long holders) {
    if (holders != 1) return false;
    const std::lock_guard<std::mutex> slot_lock(slot.mutex);
    return slot.value.expired();
  }

  std::mutex mutex_;
  std::map<Key, std::shared_ptr<Slot>> slots_;
};

}  // namespace tac3d
