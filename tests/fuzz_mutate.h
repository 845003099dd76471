#pragma once
// Seeded random mutations of a text for the fuzz targets' replay tests (the parsers' corpora
// run in the ordinary test binaries with any compiler): byte flips, random bytes, deleted
// runs, inserted TOML-significant characters, duplicated runs, truncation.

#include <random>
#include <string>

namespace hapvox::testing {

inline std::string mutate(const std::string& seed, std::mt19937_64& rng) {
  std::string s = seed;
  const int edits = 1 + static_cast<int>(rng() % 8);
  for (int e = 0; e < edits && !s.empty(); ++e) {
    const std::size_t at = rng() % s.size();
    switch (rng() % 6) {
      case 0:  // flip a bit
        s[at] = static_cast<char>(s[at] ^ (1 << (rng() % 8)));
        break;
      case 1:  // a random byte
        s[at] = static_cast<char>(rng() % 256);
        break;
      case 2:  // delete a run
        s.erase(at, 1 + rng() % 16);
        break;
      case 3:  // insert a TOML-significant character
        s.insert(at, 1, "[]{}=\"'.,#\n-+e0123456789"[rng() % 24]);
        break;
      case 4: {  // duplicate a run elsewhere (repeats keys and tables)
        const std::size_t from = rng() % s.size();
        const std::string run = s.substr(from, 1 + rng() % 40);
        s.insert(at, run);
        break;
      }
      default:  // truncate
        s.resize(at);
        break;
    }
  }
  return s;
}

}  // namespace hapvox::testing
