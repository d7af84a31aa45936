//! Measurement operators (euclidean, geodesic, circumference, geodesic loop) with exact supports, and measurement sets.
