#pragma once
// Hostile variants of an encoded LCM message, for the fuzz tests and evermap-lcm-fuzz: what a
// receiver must survive (issue 17). Each call applies one kind of damage, chosen by `rng`:
// byte flips after the type hash, a 32-bit field set to an extreme length (0, 1, 2^16, 2^28,
// 2^31 - 1, 2^31, 2^32 - 1), truncation, extension with random bytes, or (one in eight) random
// bytes behind the right type hash.

#include <cstdint>
#include <random>
#include <vector>

namespace evermap::messages {

std::vector<uint8_t> mutateLcm(const std::vector<uint8_t>& original, std::mt19937_64& rng);

}  // namespace evermap::messages
