// The family registry: see family.hpp.
#include "families/family.hpp"

#include <algorithm>
#include <array>

#include "families/family_traits.hpp"
#include "families/ifm_rm.hpp"
#include "families/novotechnik_multiturn.hpp"
#include "families/novotechnik_rotary.hpp"

namespace cobridge::families {

namespace {
// A fourth family is one more entry here (docs/adding-a-device.md).
constexpr std::array<const Family*, 3> kFamilies{&kNovotechnikRotary, &kNovotechnikMultiturn, &kIfmRm};
static_assert(kFamilies.size() == kFamilyTraits.size(), "every family has its FamilyTraits and its Family");
}  // namespace

bool Family::lists_product(std::uint32_t product) const noexcept {
  return std::any_of(models.begin(), models.end(), [product](const Model& m) {
    return std::find(m.products.begin(), m.products.end(), product) != m.products.end();
  });
}

std::span<const Family* const> all() noexcept { return kFamilies; }

const Family& family(FamilyId id) noexcept {
  switch (id) {
    case FamilyId::novotechnik_rotary: return kNovotechnikRotary;
    case FamilyId::novotechnik_multiturn: return kNovotechnikMultiturn;
    case FamilyId::ifm_rm: return kIfmRm;
  }
  return *kFamilies.front();  // unreachable: the switch names every FamilyId
}

const Model* Family::model_of(std::uint32_t product) const noexcept {
  for (const Model& m : models) {
    if (std::find(m.products.begin(), m.products.end(), product) != m.products.end()) return &m;
  }
  return nullptr;
}

const Family* find_family(std::string_view name) noexcept {
  for (const Family* f : kFamilies) {
    if (f->name == name) return f;
  }
  return nullptr;
}

const Family* family_of(std::uint32_t vendor, std::uint32_t product) noexcept {
  for (const Family* f : kFamilies) {
    if (f->vendor == vendor && (f->match_any_product || f->lists_product(product))) return f;
  }
  return nullptr;
}

ModelRef find_model(std::string_view name) noexcept {
  for (const Family* f : kFamilies) {
    for (const Model& m : f->models) {
      if (m.name == name) return {f, &m};
    }
  }
  return {};
}

std::string cite_manuals(std::string_view text) {
  static constexpr std::string_view kSection = "\u00a7";  // the section sign, UTF-8
  std::string out;
  out.reserve(text.size() + 64);
  std::size_t i = 0;
  while (i < text.size()) {
    const std::size_t at = text.find(kSection, i);
    if (at == std::string_view::npos || at == 0) break;
    const char key = text[at - 1];
    const bool starts_word = at == 1 || text[at - 2] == '(' || text[at - 2] == ' ' || text[at - 2] == '/';
    const Family* f = nullptr;
    for (const Family* c : all()) {
      if (c->manual.size() == 1 && c->manual[0] == key) f = c;
    }
    if (f == nullptr || !starts_word) {
      out.append(text.substr(i, at + kSection.size() - i));
      i = at + kSection.size();
      continue;
    }
    out.append(text.substr(i, at - 1 - i));
    out.append(f->manual_title);
    out.append(" ");
    out.append(kSection);
    i = at + kSection.size();
  }
  out.append(text.substr(i));
  return out;
}

}  // namespace cobridge::families
