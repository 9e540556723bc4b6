//! YAML specs, the stage graph, the content-hash cache and the executors.
