#pragma once
/// Heap accounting and trimming of the map's containers (GlobalMap, SpatialIndex). A long run
/// first grows and then shrinks them (cells replaced, pruned and consolidated): std containers
/// keep the capacity of their largest size, so the map gives it back once most of it is unused.
#include <cstddef>

namespace planecell::map {

/// Heap bytes of a node-based hash map: its bucket array and one node (value + next pointer) per
/// element.
template <class Map>
std::size_t hash_map_bytes(const Map& m) {
  return m.bucket_count() * sizeof(void*) +
         m.size() * (sizeof(typename Map::value_type) + sizeof(void*));
}

/// Heap bytes of a node-based ordered map or set (a red-black tree): one node per element, its
/// value after the colour word and three links (parent, left, right).
template <class Tree>
std::size_t tree_bytes(const Tree& t) {
  return t.size() * (sizeof(typename Tree::value_type) + 4 * sizeof(void*));
}

/// Rehashes `m` to fit its size when fewer than half of its buckets would be needed (more than
/// 64 buckets): amortised O(1) per erase, since the table must halve between two calls that do
/// work, and growth (which doubles the buckets when they fill) does not trigger it again.
template <class Map>
void shrink_if_sparse(Map& m) {
  if (m.bucket_count() > 64 && static_cast<double>(m.bucket_count()) * m.max_load_factor() >
                                   2.0 * static_cast<double>(m.size()))
    m.rehash(0);
}

/// Frees a vector's unused capacity when it exceeds twice its size plus four elements.
template <class Vector>
void shrink_if_sparse_vector(Vector& v) {
  if (v.capacity() > 2 * v.size() + 4) v.shrink_to_fit();
}

}  // namespace planecell::map
