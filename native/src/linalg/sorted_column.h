// One column of a compressed sparse matrix being written: its rows and values
// in parallel arrays, kept in increasing row order as entries arrive.
#pragma once

#include <algorithm>
#include <utility>
#include <vector>

namespace arap {

// Insertion costs the square of a column's length: columns longer than this
// (the hubs of Volume Infill's lattice, thousands of entries) are sorted once instead.
constexpr int kInsertionColumn = 64;

// Puts (row, value) into the column that starts at `begin` and ends at `end`
// (advanced by one), before the entries with larger rows. A mesh column holds
// a handful of entries, for which insertion is the cheapest sort. Rows must
// be distinct.
inline void insert_sorted(int* rows, double* values, int begin, int& end, int row, double value) {
  int hole = end++;
  for (; hole > begin && rows[hole - 1] > row; --hole) rows[hole] = rows[hole - 1], values[hole] = values[hole - 1];
  rows[hole] = row, values[hole] = value;
}

// Sorts the column [begin, end) by row (rows distinct): the same column insert_sorted gives.
inline void sort_column(int* rows, double* values, int begin, int end, std::vector<std::pair<int, double>>& scratch) {
  scratch.clear();
  for (int p = begin; p < end; ++p) scratch.emplace_back(rows[p], values[p]);
  std::sort(scratch.begin(), scratch.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  for (int p = begin; p < end; ++p) rows[p] = scratch[p - begin].first, values[p] = scratch[p - begin].second;
}

}  // namespace arap
