// Without libFuzzer (clang missing): a deterministic mutation loop over the
// seed corpus, run under ASan + UBSan. Usage: <target> <corpus-dir> <inputs>.
// Each seed is run as is, then mutated (byte flips, inserts, cuts, splices of
// two seeds) with a fixed-seed generator, so a failure reproduces.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

namespace {

std::uint64_t next(std::uint64_t& s) {
  s ^= s << 13;
  s ^= s >> 7;
  s ^= s << 17;
  return s;
}

std::vector<std::vector<std::uint8_t>> seeds(const char* dir) {
  std::vector<std::vector<std::uint8_t>> out;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    std::ifstream in(e.path(), std::ios::binary);
    out.emplace_back(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  if (out.empty()) out.emplace_back();
  return out;
}

void mutate(std::vector<std::uint8_t>& v, const std::vector<std::uint8_t>& other, std::uint64_t& s) {
  switch (next(s) % 4) {
    case 0:
      if (!v.empty()) v[next(s) % v.size()] ^= static_cast<std::uint8_t>(1u << (next(s) % 8));
      break;
    case 1: v.insert(v.begin() + static_cast<long>(v.empty() ? 0 : next(s) % v.size()), static_cast<std::uint8_t>(next(s))); break;
    case 2:
      if (!v.empty()) v.resize(next(s) % v.size());
      break;
    default:
      if (!other.empty()) v.insert(v.end(), other.begin() + static_cast<long>(next(s) % other.size()), other.end());
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s CORPUS_DIR INPUTS\n", argv[0]);
    return 2;
  }
  const auto corpus = seeds(argv[1]);
  const long inputs = std::strtol(argv[2], nullptr, 10);
  std::uint64_t s = 0x9E3779B97F4A7C15ull;
  for (const auto& seed : corpus) LLVMFuzzerTestOneInput(seed.data(), seed.size());
  for (long i = 0; i < inputs; ++i) {
    std::vector<std::uint8_t> v = corpus[next(s) % corpus.size()];
    const int rounds = 1 + static_cast<int>(next(s) % 8);
    for (int r = 0; r < rounds; ++r) mutate(v, corpus[next(s) % corpus.size()], s);
    LLVMFuzzerTestOneInput(v.data(), v.size());
  }
  std::printf("%ld mutated inputs, %zu seeds: no crash\n", inputs, corpus.size());
  return 0;
}
