// One column of a compressed sparse matrix being written: its rows and values
// in parallel arrays, kept in increasing row order as entries arrive.
#pragma once

namespace arap {

// Puts (row, value) into the column that starts at `begin` and ends at `end`
// (advanced by one), before the entries with larger rows. A mesh column holds
// a handful of entries, for which insertion is the cheapest sort. Rows must
// be distinct.
inline void insert_sorted(int* rows, double* values, int begin, int& end, int row, double value) {
  int hole = end++;
  for (; hole > begin && rows[hole - 1] > row; --hole) rows[hole] = rows[hole - 1], values[hole] = values[hole - 1];
  rows[hole] = row, values[hole] = value;
}

}  // namespace arap
