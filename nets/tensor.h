// A dense tensor for the networks: contiguous, row-major (last index fastest), batch first.
// Layouts used by the layers: images/feature maps N x C x H x W, point sets N x P x C, vectors N x C.
// Templated on the scalar: the networks run in float, the gradient checks in double.
#pragma once

#include "core/error.h"

#include <Eigen/Core>

#include <algorithm>
#include <cstdint>
#include <initializer_list>
#include <string>
#include <vector>

namespace sdfkit {

using Shape = std::vector<int64_t>;

/// Storage of every tensor, parameter and gradient buffer: aligned to Eigen's largest packet (64 bytes with
/// AVX-512). Eigen's vectorised reductions (sum, dot, colwise sums) peel scalar elements until the first aligned
/// address, so on storage with a varying alignment the summation order, and the last bits of the result, would
/// depend on where the allocator put the buffer: a resumed run would then not continue bit for bit.
template <typename T>
using AlignedVector = std::vector<T, Eigen::aligned_allocator<T>>;

/// "[2, 3, 4]" for messages.
std::string shape_string(const Shape& shape);
/// Product of the dimensions (1 for a scalar shape {}).
int64_t shape_size(const Shape& shape);

template <typename T>
using MatRowT = Eigen::Matrix<T, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
template <typename T>
using MatMapT = Eigen::Map<MatRowT<T>>;
template <typename T>
using ConstMatMapT = Eigen::Map<const MatRowT<T>>;

template <typename T>
struct TensorT {
  Shape shape;
  AlignedVector<T> data;

  TensorT() = default;
  explicit TensorT(Shape s, T value = T(0)) : shape(std::move(s)), data(static_cast<size_t>(shape_size(shape)), value) {}

  [[nodiscard]] int rank() const { return static_cast<int>(shape.size()); }
  [[nodiscard]] int64_t dim(int i) const { return shape.at(static_cast<size_t>(i < 0 ? i + rank() : i)); }
  [[nodiscard]] int64_t size() const { return static_cast<int64_t>(data.size()); }
  [[nodiscard]] bool empty() const { return data.empty(); }
  /// Number of batch items (first dimension) and the size of one item.
  [[nodiscard]] int64_t batch() const { return shape.empty() ? 1 : shape[0]; }
  [[nodiscard]] int64_t item_size() const { return shape.empty() ? 1 : size() / std::max<int64_t>(1, shape[0]); }

  T* ptr() { return data.data(); }
  const T* ptr() const { return data.data(); }
  T* item(int64_t n) { return data.data() + n * item_size(); }
  const T* item(int64_t n) const { return data.data() + n * item_size(); }
  T& operator[](int64_t i) { return data[static_cast<size_t>(i)]; }
  const T& operator[](int64_t i) const { return data[static_cast<size_t>(i)]; }

  /// Set the shape; storage is reused (values are unspecified unless the size grew, then new ones are 0).
  void resize(const Shape& s) {
    shape = s;
    data.resize(static_cast<size_t>(shape_size(s)));
  }
  /// Set the shape and fill with `value`.
  void assign(const Shape& s, T value) {
    shape = s;
    data.assign(static_cast<size_t>(shape_size(s)), value);
  }
  void fill(T value) { std::fill(data.begin(), data.end(), value); }
  /// Same data, new shape of the same size (InvalidInput otherwise).
  void reshape(const Shape& s) {
    require(shape_size(s) == size(), "tensor reshape " + shape_string(shape) + " -> " + shape_string(s) +
                                         ": sizes differ");
    shape = s;
  }

  /// The whole data as a rows x cols row-major matrix (rows * cols == size()).
  MatMapT<T> mat(int64_t rows, int64_t cols) { return MatMapT<T>(data.data(), rows, cols); }
  ConstMatMapT<T> mat(int64_t rows, int64_t cols) const { return ConstMatMapT<T>(data.data(), rows, cols); }
  /// The data as (size / last dim) x last dim: one row per point / vector.
  MatMapT<T> rows_by_last() { return mat(size() / dim(-1), dim(-1)); }
  ConstMatMapT<T> rows_by_last() const { return mat(size() / dim(-1), dim(-1)); }

  template <typename U>
  [[nodiscard]] TensorT<U> cast() const {
    TensorT<U> out;
    out.shape = shape;
    out.data.assign(data.begin(), data.end());
    return out;
  }
};

/// TensorT<T> in a position that does not take part in template deduction (so `nullptr` can be passed).
template <typename T>
struct NoDeduce {
  using type = T;
};
template <typename T>
using TensorOut = typename NoDeduce<TensorT<T>>::type*;

using Tensor = TensorT<float>;
using TensorD = TensorT<double>;

/// Throw InvalidInput unless `t` has rank `rank` (what names the operation for the message).
template <typename T>
void require_rank(const TensorT<T>& t, int rank, const char* what) {
  require(t.rank() == rank, std::string(what) + ": expected a rank-" + std::to_string(rank) + " tensor, got " +
                                shape_string(t.shape));
}

}  // namespace sdfkit
