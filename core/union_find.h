// Disjoint sets over the indices 0..n-1: path halving, union by smaller root. A set's root is its smallest index
// whatever the order of the unions, so results that depend on roots are deterministic. Unions of disjoint index
// ranges may run in parallel (find only touches the sets it walks).
#pragma once

#include <cstddef>
#include <cstdint>
#include <numeric>
#include <utility>
#include <vector>

namespace sdfkit {

class UnionFind {
 public:
  explicit UnionFind(size_t n = 0) { reset(n); }
  /// n singletons.
  void reset(size_t n) {
    parent_.resize(n);
    std::iota(parent_.begin(), parent_.end(), 0);
  }
  [[nodiscard]] size_t size() const { return parent_.size(); }
  int32_t find(int32_t x) {
    while (parent_[static_cast<size_t>(x)] != x) {
      parent_[static_cast<size_t>(x)] = parent_[static_cast<size_t>(parent_[static_cast<size_t>(x)])];
      x = parent_[static_cast<size_t>(x)];
    }
    return x;
  }
  /// Joins the sets of a and b; false when they were one set already.
  bool unite(int32_t a, int32_t b) {
    a = find(a);
    b = find(b);
    if (a == b) return false;
    if (a < b) std::swap(a, b);
    parent_[static_cast<size_t>(a)] = b;
    return true;
  }

 private:
  std::vector<int32_t> parent_;
};

}  // namespace sdfkit
