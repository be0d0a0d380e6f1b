// Robustness of the CiA 306 parser against garbage: random bytes, every
// truncation of a valid file and random single-byte mutations must neither
// crash nor throw, and every failure must come with located errors.
// (Deterministic seeds, so a failure reproduces.)
#include "device/eds.hpp"

#include "unit/device/source_paths.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <iterator>
#include <random>
#include <string>

using namespace cobridge::device;
using cobridge::device::test::fixture;

namespace {

std::string read(const std::string& name) {
  std::ifstream in(fixture(name), std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// Either a description, or errors that all name the file, a plausible line
// and a message; the error list is bounded.
void check_result(const EdsResult& r, const std::string& text) {
  const std::size_t lines = static_cast<std::size_t>(std::count(text.begin(), text.end(), '\n')) + 1;
  if (r.ok()) {
    EXPECT_TRUE(r.errors.empty());
    return;
  }
  ASSERT_FALSE(r.errors.empty());
  EXPECT_LE(r.errors.size(), 65U);
  for (const auto& e : r.errors) {
    EXPECT_EQ(e.file, "fuzz.eds");
    EXPECT_LE(e.line, lines);
    EXPECT_FALSE(e.message.empty());
  }
}

}  // namespace

// CiA 306 §4.1: the input is text; arbitrary bytes are rejected cleanly.
TEST(EdsFuzz, RandomBytesNeverCrash_CiA306_4_1) {
  std::mt19937 rng(306);
  std::uniform_int_distribution<int> byte(0, 255);
  std::uniform_int_distribution<std::size_t> length(0, 3000);
  for (int i = 0; i < 500; ++i) {
    std::string text(length(rng), '\0');
    for (char& c : text) c = static_cast<char>(byte(rng));
    const EdsResult r = parse_eds(text, "fuzz.eds");
    check_result(r, text);
  }
}

// Random printable text built from EDS tokens: closer to real files, so the
// interpreter (not only the lexer) sees garbage.
TEST(EdsFuzz, RandomEdsTokensNeverCrash_CiA306_4_1) {
  static const char* const kTokens[] = {
      "[", "]", "=", "\n", "\r\n", ";", " ", "sub", "0x", "$NODEID", "+", "-", "1000", "1018", "6000", "FFFF",
      "ParameterName", "ObjectType", "DataType", "AccessType", "DefaultValue", "LowLimit", "HighLimit",
      "PDOMapping", "SubNumber", "SupportedObjects", "MandatoryObjects", "OptionalObjects", "DeviceInfo",
      "FileInfo", "VendorNumber", "0x7", "0x8", "0x9", "rw", "ro", "const", "18446744073709551615", "99999999999999999999",
      "0x0007", "0x0004", "1", "0", "Cobridge", "VariantProbe", "0x6020sub0", "CompactSubObj"};
  std::mt19937 rng(406);
  std::uniform_int_distribution<std::size_t> pick(0, std::size(kTokens) - 1);
  std::uniform_int_distribution<int> count(0, 600);
  for (int i = 0; i < 500; ++i) {
    std::string text;
    for (int n = count(rng); n > 0; --n) text += kTokens[pick(rng)];
    const EdsResult r = parse_eds(text, "fuzz.eds");
    check_result(r, text);
  }
}

// Every prefix of a valid file: parsing stops anywhere.
TEST(EdsFuzz, EveryTruncationOfAGoodFile_CiA306_4_1) {
  const std::string good = read("good_minimal.eds");
  ASSERT_GT(good.size(), 1000U);
  ASSERT_TRUE(parse_eds(good, "fuzz.eds").ok());
  for (std::size_t n = 0; n < good.size(); ++n) {
    const std::string text = good.substr(0, n);
    const EdsResult r = parse_eds(text, "fuzz.eds");
    check_result(r, text);
    if (n < good.size() / 2) {
      EXPECT_FALSE(r.ok()) << "prefix of " << n << " bytes parsed";
    }
  }
}

TEST(EdsFuzz, RandomByteMutationsOfAGoodFile_CiA306_4_1) {
  const std::string good = read("good_minimal.eds");
  std::mt19937 rng(301);
  std::uniform_int_distribution<std::size_t> where(0, good.size() - 1);
  std::uniform_int_distribution<int> byte(0, 255);
  for (int i = 0; i < 2000; ++i) {
    std::string text = good;
    for (int k = 0; k < 1 + i % 4; ++k) text[where(rng)] = static_cast<char>(byte(rng));
    const EdsResult r = parse_eds(text, "fuzz.eds");
    check_result(r, text);
  }
}
