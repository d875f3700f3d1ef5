// The index from body names to BodyIds of a World: a FlatMap whose keys pair a name's hash with
// its id, so that a lookup reads one line of the table and then the record the id points to,
// where the caller keeps the name. It does not own or copy names, and it is not thread-safe
// for writes.
#pragma once

#include "vadop/detail/flat_map.h"

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string_view>

namespace vadop {
namespace detail {

class NameIndex {
 public:
  static constexpr uint32_t kNone = ~uint32_t{0};

  size_t size() const { return map_.size(); }
  // The id listed under `name`, or kNone; nameOf(id) gives the name the caller keeps for id.
  template <class NameOf>
  uint32_t find(std::string_view name, const NameOf& nameOf) const {
    const uint32_t hash = hashOf(name);
    const uint32_t* id = map_.findIf(hash, isNamed(hash, name, nameOf));
    return id ? *id : kNone;
  }
  // Room for `count` names: insert() of up to that many does not allocate. May throw
  // std::bad_alloc (nothing changed then).
  void reserve(size_t count) { map_.reserve(count); }
  // Lists `name` (absent) under `id`; the room must have been reserved: does not throw.
  void insert(std::string_view name, uint32_t id) noexcept { map_.insert(keyOf(hashOf(name), id), id); }
  // Unlists `name` if listed; does not throw.
  template <class NameOf>
  void erase(std::string_view name, const NameOf& nameOf) noexcept {
    const uint32_t hash = hashOf(name);
    map_.eraseIf(hash, isNamed(hash, name, nameOf));
  }
  // f(id) for every listed id, in table order.
  template <class F>
  void forEach(const F& f) const {
    map_.forEach([&f](uint64_t, uint32_t id) { f(id); });
  }

 private:
  // A key: the name's hash in the high half (the table's hash), the id in the low half.
  struct KeyHash {
    size_t operator()(uint64_t key) const { return static_cast<size_t>(key >> 32); }
  };
  using Map = FlatMap<uint64_t, uint32_t, KeyHash>;
  static uint64_t keyOf(uint32_t hash, uint32_t id) { return (static_cast<uint64_t>(hash) << 32) | id; }
  static uint32_t hashOf(std::string_view name) {
    const uint64_t h = std::hash<std::string_view>{}(name);
    return static_cast<uint32_t>(h ^ (h >> 32));
  }
  template <class NameOf>
  static auto isNamed(uint32_t hash, std::string_view name, const NameOf& nameOf) {
    return [hash, name, &nameOf](uint64_t key) {
      return static_cast<uint32_t>(key >> 32) == hash && nameOf(static_cast<uint32_t>(key)) == name;
    };
  }

  Map map_;
};

}  // namespace detail
}  // namespace vadop
