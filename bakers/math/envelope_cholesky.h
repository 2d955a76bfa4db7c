// A direct solver for small sparse symmetric positive definite systems: the Cholesky factor A = L Lᵀ of the matrix
// reordered by reverse Cuthill–McKee, stored by its envelope.
//
// Reverse Cuthill–McKee numbers the unknowns breadth first from a far end of the matrix's graph (George and Liu's
// pseudo-peripheral node), each level's neighbours by increasing degree, and reverses the order; for graphs that are
// long and thin (the texels along a seam) this puts every row's entries close to the diagonal. Row i of L is then
// nonzero only from first(i), the leftmost column of row i of the reordered A, to the diagonal: Cholesky fills no entry
// outside that envelope (George and Liu, "Computer Solution of Large Sparse Positive Definite Systems", ch. 4), so the
// factor is stored as one dense run per row. Factoring costs the sum over rows of (i − first(i))² / 2, and a solve
// two passes over the runs.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace kiln {

// Rows [lo, hi) of a symmetric matrix in compressed rows: row r's entries are value[e] at column col[e] for e in
// [row_start[r], row_start[r + 1]), both triangles stored, every column inside [lo, hi) (a block that couples to no
// other row).
struct SymmetricBlock {
  const std::vector<uint32_t>& row_start;
  const std::vector<uint32_t>& col;
  const std::vector<double>& value;
  uint32_t lo, hi;
};

class EnvelopeCholesky {
 public:
  // Factors the block. Returns false, holding nothing, when the envelope would hold more than `max_entries` values or
  // a pivot is not positive (the matrix is not positive definite to double precision); the caller then solves by
  // other means. Deterministic: the ordering breaks every tie by the lower row.
  bool factor(const SymmetricBlock& a, size_t max_entries);

  // Solves A x = b for the factored block: `x` holds b on entry (hi − lo values, row lo first) and x on return.
  void solve(double* x) const;

  size_t size() const { return order_.size(); }
  size_t entries() const { return values_.size(); }  // the envelope's values, diagonal included
  size_t bytes() const;                              // held, with the ordering and the runs' bounds
  // What a factor of `rows` rows and `entries` values holds (bytes()), and the most factor() holds beside it while it
  // works, per row: the ordering's degrees, marks and queues, or the rows' new positions.
  static size_t bytes_for(size_t rows, size_t entries);
  static constexpr size_t kWorkBytesPerRow = 32;

 private:
  std::vector<uint32_t> order_;  // new position → row − lo
  std::vector<uint32_t> first_;  // per new row: its envelope's first column
  std::vector<size_t> start_;    // per new row: where its run begins in values_ (the run ends at its diagonal)
  std::vector<double> values_;

  void clear();
};

// The reverse Cuthill–McKee order of the block's rows: new position → row − lo. Every connected part is numbered from
// a pseudo-peripheral row of it, parts in order of their lowest row.
std::vector<uint32_t> reverse_cuthill_mckee(const SymmetricBlock& a);

}  // namespace kiln
