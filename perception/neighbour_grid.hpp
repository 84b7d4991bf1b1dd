// Two steps of the paper's pipeline with the neighbours found through a grid of cells, where PCL makes a k-d
// tree query per point: its statistical outlier removal (once the biggest single cost of the randomized
// benchmark) and its Euclidean clusters. Same steps and arithmetic as pcl::StatisticalOutlierRemoval and
// pcl::EuclideanClusterExtraction: the same points kept, the same clusters in the same order
// (neighbour_grid_test); `weldtwin_bench --benchmark_filter='OutlierFilter|EuclideanClusters'` compares them.
#pragma once

#include <Eigen/Core>
#include <vector>

namespace weldtwin {

/// The mean distance of each point to its `mean_k` nearest neighbours, as PCL's filter computes it (the
/// square roots summed in double in another order: the same float but for rare ties in rounding); 0 for a
/// non-finite point.
///
/// The neighbours of all points of a cell are sought among the points of the 3 x 3 x 3 cells around it
/// (gathered once for the cell); a point's k-th distance found there is the cloud's when it is nearer than
/// the block's nearest face, otherwise wider blocks around the point answer. The cell is the distance within
/// which nine in ten points have their neighbours. The nearest are selected, not sorted: quickselect about
/// the last point's k-th distance, with branch-free partitions.
std::vector<float> mean_neighbour_distances(const std::vector<Eigen::Vector3f>& points, int mean_k);

/// A point whose mean distance to its `mean_k` nearest neighbours is more than `stddev_mul` standard
/// deviations above the mean of those distances is an outlier. Non-finite points are kept, as PCL keeps them.
/// Returns the indices of the points kept, in order.
std::vector<int> statistical_inliers(const std::vector<Eigen::Vector3f>& points, int mean_k,
                                     double stddev_mul);

/// PCL's Euclidean cluster extraction (`pcl::EuclideanClusterExtraction`): the connected sets of points
/// chained by neighbours nearer than `tolerance`, with `min_size` to `max_size` points; each cluster's
/// indices ascending, the clusters in PCL's order (by the first index, then PCL's sort by size, largest
/// first). The neighbours of a grid cell's points are sought in the cells around it and joined by union-find,
/// where PCL grows each cluster by a radius search per point.
std::vector<std::vector<int>> euclidean_clusters(const std::vector<Eigen::Vector3f>& points, float tolerance,
                                                 size_t min_size, size_t max_size);

}  // namespace weldtwin
