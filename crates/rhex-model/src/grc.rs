//! Ground reaction complex (thesis ch. 3). Work in progress.
