// DeviceCatalog: every device description the gateway knows, loaded from the
// EDS files of one or more directories, and the rule that picks the
// description for a device found on the bus by its identity (CiA 301 object
// 0x1018: vendor, product, revision) and, where one product comes in
// variants, by the variant.
//
// Thread contract: loading runs on the start-up / reload thread (file I/O,
// allocation). Once loaded the catalog is not modified; lookups are const and
// may run concurrently from any thread, but never on the per-frame path.
//
// Selection rule:
//   1. Candidates are the descriptions whose VendorNumber matches and whose
//      ProductNumber or [Cobridge] AdditionalProductNumbers contains the
//      product; if there are none, the vendor's descriptions marked
//      MatchAnyProduct=1 (for devices whose product code is unreliable).
//   2. If a variant is given, only descriptions of that variant remain.
//   3. Among the rest, the one with the highest RevisionNumber that is <= the
//      device's revision wins (a description covers its revision and later
//      ones until a newer file exists); without a revision, the highest.
//   Ambiguity (several variants left, no variant given) selects nothing; the
//   caller reads each candidate's VariantProbe object and asks again.
#pragma once

#include "device/eds.hpp"

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string_view>
#include <vector>

namespace cobridge::device {

class DeviceCatalog {
 public:
  // Loads every *.eds (any case) directly in `dir`, in file-name order.
  // Files with errors are skipped; their errors, and duplicate identities,
  // are returned (and kept in errors()). Returns the errors of this call.
  std::vector<EdsError> load_directory(const std::filesystem::path& dir) noexcept;
  // Loads one file.
  std::vector<EdsError> load_file(const std::filesystem::path& path) noexcept;
  // Adds an already parsed description (tests, embedded descriptions).
  std::vector<EdsError> add(DeviceDescription description) noexcept;

  // See the selection rule above. nullptr if nothing or several match.
  [[nodiscard]] const DeviceDescription* select(std::uint32_t vendor, std::uint32_t product,
                                                std::optional<std::uint32_t> revision = std::nullopt,
                                                std::string_view variant = {}) const noexcept;
  // Steps 1 and 3 of the rule for every variant: the descriptions among
  // which a variant probe decides.
  [[nodiscard]] std::vector<const DeviceDescription*> candidates(
      std::uint32_t vendor, std::uint32_t product, std::optional<std::uint32_t> revision = std::nullopt) const;

  [[nodiscard]] std::size_t size() const noexcept { return descriptions_.size(); }
  [[nodiscard]] const std::vector<EdsError>& errors() const noexcept { return errors_; }
  // check_eds (device/eds_check.hpp) over every loaded description: what a
  // third-party master importing these files would get wrong. Advisory: a
  // description with findings stays loaded. Off the hot path (allocates).
  [[nodiscard]] std::vector<Error> check() const;
  // All loaded descriptions in load order.
  [[nodiscard]] std::vector<const DeviceDescription*> all() const;

 private:
  std::vector<EdsError> add_checked(DeviceDescription description);
  std::vector<const DeviceDescription*> matching(std::uint32_t vendor, std::uint32_t product,
                                                 std::optional<std::uint32_t> revision,
                                                 std::optional<std::string_view> variant) const;

  // unique_ptr keeps descriptions at stable addresses while the vector grows.
  std::vector<std::unique_ptr<const DeviceDescription>> descriptions_;
  std::vector<EdsError> errors_;
};

}  // namespace cobridge::device
