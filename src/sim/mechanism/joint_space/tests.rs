//! The joint-space step against the maximal step (the same discrete equations) and against
//! the articulated-body solve's dense counterpart.
