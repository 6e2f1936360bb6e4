// Ring codes of circular coded targets: which ring patterns are targets and what their IDs are.
//
// A coded target is a dot of radius r (the measured point) inside a ring of `bits` equal angular
// segments; a segment printed in the dot's colour is a 1 bit. The ring is read clockwise as seen
// on the printed sheet (x right, y down), the first segment read being the most significant bit.
// Where the reading starts is unknown in an image, so a code is known only up to rotation: every
// code is stored in its canonical form, the smallest value among its `bits` cyclic rotations
// (the necklace's least representative). A profile is a rule saying which canonical codes are
// targets; its IDs number the admitted codes in ascending canonical value from 1.
//
// Profiles (docs/targets.md gives the sources and the counts, coded_test.cc checks them):
//  - AICON (Schneider 1991; expired patent DE19733466A1, as implemented by M. Petroff 2018):
//    an even number of 1s and at least one pair of diametrically opposite segments both 1, not
//    the full ring. 12 bits: 147 codes, 14 bits: 516. Ring from 2r to 3r.
//  - Metashape (Agisoft's "circular 12/14 bit" targets): an even number of 1s, at least four 1s
//    and at least one 0, and no run of 0s (cyclically) longer than bits/2 − 1.
//    12 bits: 161 codes, 14 bits: 561. Ring from about 2.25r to 3.5r.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace porthole::coded {

enum class Profile { kAicon, kMetashape };

// "aicon" or "metashape" (any case); throws InvalidInput(field, ...) otherwise.
Profile ParseProfile(const std::string& name, const std::string& field = "profile");
std::string ProfileName(Profile p);

// Radii of the code ring's inner and outer edges in units of the dot radius.
struct RingRadii {
  double inner = 2.0;
  double outer = 3.0;
};
RingRadii Ring(Profile p);

// Throws InvalidInput(field, ...) unless bits is 12 or 14.
void ValidateBits(int bits, const std::string& field = "bits");

// The smallest of the `bits` cyclic rotations of the low `bits` bits of `code`.
uint32_t MinimalRotation(uint32_t code, int bits);

// Whether a canonical code (MinimalRotation(c) == c) is admitted by the profile's rule.
bool Admitted(Profile p, int bits, uint32_t canonical);

// The admitted canonical codes in ascending order: ID k is Codes(p, bits)[k − 1].
const std::vector<uint32_t>& Codes(Profile p, int bits);

// The ID (1 …) of a ring read from any starting segment, or 0 when no target of the profile has
// that ring (an impossible code).
int IdOfRing(Profile p, int bits, uint32_t ring);

// The canonical code of ID `id`; throws InvalidInput(field, ...) when the profile has no such ID.
uint32_t CodeOfId(Profile p, int bits, int id, const std::string& field = "first_id");

}  // namespace porthole::coded
