#include "bus/restore_guard.hpp"

#include <algorithm>

namespace cobridge::bus {
RestoreGuard::Decision RestoreGuard::on_drift(std::uint16_t index, std::uint8_t sub, canopen::TimePoint now) {
  Object& o = object(object_number(index, sub));
  Decision d;
  if (o.contested) {
    d.verdict = Verdict::held;
    d.restores = static_cast<unsigned>(o.restores.size());
    return d;
  }
  std::erase_if(o.restores, [&](canopen::TimePoint t) { return now - t >= limits_.window; });
  const std::size_t done = o.restores.size();
  d.restores = static_cast<unsigned>(done);
  if (done >= RestoreLimits::kMaxRestores) {
    o.contested = true;
    d.verdict = Verdict::contested;
    return d;
  }
  o.restores.push_back(now);
  d.not_before = now + limits_.backoff[done];
  d.restores = static_cast<unsigned>(done + 1);
  return d;
}

bool RestoreGuard::contested(std::uint16_t index, std::uint8_t sub) const {
  const Object* o = find(object_number(index, sub));
  return o != nullptr && o->contested;
}

bool RestoreGuard::any_contested() const {
  return std::any_of(objects_.begin(), objects_.end(), [](const Object& o) { return o.contested; });
}

std::size_t RestoreGuard::acknowledge() {
  const auto n = static_cast<std::size_t>(std::count_if(objects_.begin(), objects_.end(),
                                                        [](const Object& o) { return o.contested; }));
  objects_.clear();
  return n;
}

RestoreGuard::Object& RestoreGuard::object(std::uint32_t key) {
  for (auto& o : objects_) {
    if (o.key == key) return o;
  }
  objects_.push_back(Object{key, {}, false});
  return objects_.back();
}

const RestoreGuard::Object* RestoreGuard::find(std::uint32_t key) const {
  for (const auto& o : objects_) {
    if (o.key == key) return &o;
  }
  return nullptr;
}

}  // namespace cobridge::bus
