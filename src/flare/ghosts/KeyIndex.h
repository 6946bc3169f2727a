// Lattice keys to indices for the pupil mesher: open addressing with linear probing, faster than
// std::unordered_map for the mesher's many small lookups (the 4 × 4 blocks around each cell
// judged), and for the beams' vertices and rim edges. Keys are 64-bit lattice, edge or hashed keys;
// ~0 is reserved (keyIndexKey).
#pragma once

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace flare {

class KeyIndex {
public:
    KeyIndex() : keys_(64, kEmpty), values_(64, -1) {}
    // The value stored under key, or -1.
    int find(std::uint64_t key) const {
        for (size_t slot = hash(key);; slot = (slot + 1) & (keys_.size() - 1)) {
            if (keys_[slot] == key) return values_[slot];
            if (keys_[slot] == kEmpty) return -1;
        }
    }
    // Stores value under key unless the key is there; returns the stored value and whether it
    // was inserted.
    std::pair<int, bool> emplace(std::uint64_t key, int value) {
        if (2 * (size_ + 1) > keys_.size()) grow();
        for (size_t slot = hash(key);; slot = (slot + 1) & (keys_.size() - 1)) {
            if (keys_[slot] == key) return {values_[slot], false};
            if (keys_[slot] == kEmpty) {
                keys_[slot] = key;
                values_[slot] = value;
                ++size_;
                return {value, true};
            }
        }
    }
    bool contains(std::uint64_t key) const { return find(key) >= 0; }
    // Room for `entries` keys without growing (an empty index only): a beam's mesh knows about how
    // many vertices and edges it will hold, and growing by doubling rehashed each key about twice.
    void reserve(size_t entries) {
        if (size_ != 0) return;
        int log2 = 6;
        while ((size_t{1} << log2) < 2 * entries + 2) ++log2;
        if ((size_t{1} << log2) <= keys_.size()) return;
        keys_.assign(size_t{1} << log2, kEmpty);
        values_.assign(keys_.size(), -1);
        shift_ = 64 - log2;
    }
    bool empty() const { return size_ == 0; }

private:
    static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};  // no lattice or edge key
    // Fibonacci hashing: the product's top bits depend on all of the key's bits.
    size_t hash(std::uint64_t key) const { return static_cast<size_t>((key * 0x9E3779B97F4A7C15ull) >> shift_); }
    void grow() {
        std::vector<std::uint64_t> keys(keys_.size() * 2, kEmpty);
        std::vector<int> values(keys.size(), -1);
        keys.swap(keys_);
        values.swap(values_);
        size_ = 0;
        --shift_;
        for (size_t k = 0; k < keys.size(); ++k)
            if (keys[k] != kEmpty) emplace(keys[k], values[k]);
    }
    std::vector<std::uint64_t> keys_;
    std::vector<int> values_;
    size_t size_ = 0;
    int shift_ = 64 - 6;  // 64 − log2(capacity)
};

// A hashed key made storable: the reserved ~0 becomes its neighbour (two hashes that meet there
// are then one key, as two that collide anyway are).
inline std::uint64_t keyIndexKey(std::uint64_t hashed) { return hashed == ~std::uint64_t{0} ? hashed - 1 : hashed; }

}  // namespace flare
