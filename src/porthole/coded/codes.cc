#include "porthole/coded/codes.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cctype>

#include "porthole/core/error.h"

namespace porthole::coded {
namespace {

uint32_t Mask(int bits) { return (uint32_t{1} << bits) - 1; }

uint32_t RotateLeft(uint32_t v, int k, int bits) {
  return k == 0 ? v : (((v << k) | (v >> (bits - k))) & Mask(bits));
}

// Longest run of 0s going round the ring (the ring has at least one 1).
int LongestZeroRunCyclic(uint32_t code, int bits) {
  int best = 0, run = 0;
  for (int i = 0; i < 2 * bits; ++i) {
    if ((code >> (i % bits)) & 1u) {
      run = 0;
    } else {
      best = std::max(best, ++run);
    }
  }
  return std::min(best, bits);
}

std::vector<uint32_t> Enumerate(Profile p, int bits) {
  std::vector<uint32_t> out;
  for (uint32_t c = 0; c <= Mask(bits); ++c) {
    if (MinimalRotation(c, bits) == c && Admitted(p, bits, c)) out.push_back(c);
  }
  return out;
}

}  // namespace

Profile ParseProfile(const std::string& name, const std::string& field) {
  std::string s = name;
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  if (s == "aicon") return Profile::kAicon;
  if (s == "metashape") return Profile::kMetashape;
  throw InvalidInput(field, "the code profile must be aicon or metashape, got '" + name + "'");
}

std::string ProfileName(Profile p) { return p == Profile::kAicon ? "aicon" : "metashape"; }

RingRadii Ring(Profile p) { return p == Profile::kAicon ? RingRadii{2.0, 3.0} : RingRadii{2.25, 3.5}; }

void ValidateBits(int bits, const std::string& field) {
  if (bits != 12 && bits != 14) throw InvalidInput(field, fmt::format("the code has 12 or 14 bits, got {}", bits));
}

uint32_t MinimalRotation(uint32_t code, int bits) {
  code &= Mask(bits);
  uint32_t best = code;
  for (int k = 1; k < bits; ++k) best = std::min(best, RotateLeft(code, k, bits));
  return best;
}

bool Admitted(Profile p, int bits, uint32_t c) {
  const int ones = std::popcount(c & Mask(bits));
  if (ones % 2 != 0 || ones == 0 || ones == bits) return false;  // even weight, not empty, not full
  if (p == Profile::kAicon) {
    const int half = bits / 2;
    return ((c & Mask(half)) & (c >> half)) != 0;  // a diametrically opposite pair of 1s
  }
  return ones >= 4 && LongestZeroRunCyclic(c, bits) <= bits / 2 - 1;
}

const std::vector<uint32_t>& Codes(Profile p, int bits) {
  ValidateBits(bits, "bits");
  static const std::array<std::vector<uint32_t>, 4> kLists = {
      Enumerate(Profile::kAicon, 12), Enumerate(Profile::kAicon, 14),
      Enumerate(Profile::kMetashape, 12), Enumerate(Profile::kMetashape, 14)};
  return kLists[(p == Profile::kMetashape ? 2 : 0) + (bits == 14 ? 1 : 0)];
}

int IdOfRing(Profile p, int bits, uint32_t ring) {
  const auto& list = Codes(p, bits);
  const uint32_t c = MinimalRotation(ring, bits);
  const auto it = std::lower_bound(list.begin(), list.end(), c);
  return it != list.end() && *it == c ? static_cast<int>(it - list.begin()) + 1 : 0;
}

uint32_t CodeOfId(Profile p, int bits, int id, const std::string& field) {
  const auto& list = Codes(p, bits);
  if (id < 1 || id > static_cast<int>(list.size())) {
    throw InvalidInput(field, fmt::format("{} {}-bit targets have IDs 1 to {}, got {}", ProfileName(p), bits,
                                          list.size(), id));
  }
  return list[id - 1];
}

}  // namespace porthole::coded
