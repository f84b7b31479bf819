// The elimination order of a sparse Cholesky factorisation of J^T J,
// chosen on the pattern of parameter blocks (which pairs share a residual).
//
// Ceres orders the blocks for SPARSE_NORMAL_CHOLESKY by approximate minimum
// degree (AMD) when it is given no ordering. The joint stage's pattern is a
// long chain (the trajectory's nodes) with a few hubs (the cameras), each
// tied to the nodes of every pass under it. On it AMD eliminates the chain
// from its ends and every node it reaches inherits the hubs of the part
// already eliminated: on `paper_det` with all blobs the factor needs 6.6e8
// flops. Nested dissection (METIS, through CHOLMOD's partition module) cuts
// the chain between passes first and needs 2.0e8 (doc/benchmarks-history.md,
// "The elimination order of J^T J"). Neither wins everywhere (with 60 blobs per camera AMD
// needs 7.0e7 and nested dissection 8.2e7), so kAuto computes both and
// predicts their flops from the symbolic factorisation of the block pattern
// (a few milliseconds; the factorisation is repeated at every step). Flops
// are not all of the time: on the 1,000-camera facility nested dissection
// predicted 0.98x AMD's flops and its factorisations took 1.2x AMD's time.
// So it is taken only when it predicts clearly fewer, below
// kNestedDissectionMargin of AMD's.
#pragma once
#include <ceres/ordered_groups.h>
#include <ceres/problem.h>

#include <memory>
#include <string>
#include <vector>

namespace lookboth {

/// J^T J's block pattern: block i's tangent size and the blocks it shares a
/// residual with (any order; itself and duplicates are allowed).
struct BlockPattern {
  std::vector<int> block_size;
  std::vector<std::vector<int>> adjacent;
};

constexpr double kNestedDissectionMargin = 0.6;

enum class FillOrderingMethod {
  kAmd,               ///< approximate minimum degree (what Ceres does unasked)
  kNestedDissection,  ///< METIS' nested dissection, postordered
  kAuto,              ///< both; nested dissection when it predicts clearly fewer flops
};

/// "amd", "nested_dissection" or "auto"; false for anything else.
bool parseFillOrderingMethod(const std::string& text, FillOrderingMethod* method);
const char* fillOrderingMethodName(FillOrderingMethod method);

struct FillOrdering {
  std::vector<int> order;                                ///< blocks, eliminated first to last
  FillOrderingMethod method = FillOrderingMethod::kAmd;  ///< the one used (never kAuto)
  double predicted_flops = 0;                            ///< of the scalar factorisation
  double predicted_flops_other = 0;                      ///< kAuto: the one not used (else 0)
};

/// The order of every block of `pattern`. False (and *message) when CHOLMOD
/// fails, e.g. out of memory.
bool orderBlocks(const BlockPattern& pattern, FillOrderingMethod method, FillOrdering* ordering,
                 std::string* message);

/// Flops of the scalar LL^T factorisation in block order `order`, predicted
/// from the symbolic factorisation of the block pattern (each block column
/// counted with its size, its rows with the sizes of the blocks below it).
double predictedFactorisationFlops(const BlockPattern& pattern, const std::vector<int>& order);

/// For Solver::Options::linear_solver_ordering with SPARSE_NORMAL_CHOLESKY:
/// one group per parameter block, in the order orderBlocks() gives for the
/// pattern of the problem's free blocks (constant blocks, which Ceres removes,
/// go last). Null when AMD is chosen (*chosen says so, *message is empty):
/// Ceres' own ordering, the same method, is then used unchanged. Null with
/// *message when the ordering could not be computed (the same fallback).
std::shared_ptr<ceres::ParameterBlockOrdering> solverOrdering(const ceres::Problem& problem,
                                                              FillOrderingMethod method,
                                                              FillOrdering* chosen,
                                                              std::string* message);

}  // namespace lookboth
