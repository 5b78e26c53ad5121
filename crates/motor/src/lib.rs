//! Actuators (thesis chapter 2). Work in progress.
