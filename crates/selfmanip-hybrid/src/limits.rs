//! The contact solvers' fixed size limit, where exact enumeration gives way to the QP.

/// Up to this many candidate contacts the complementarity problems are solved by exact
/// enumeration of their `2ⁿ` subsets (an impact solving only the subsets its verdict needs,
/// [`crate::complementarity`]); beyond it by the convex QP of [`crate::impact_qp`].
pub const ENUMERATION_LIMIT: usize = 10;
