//! Small specifications for testing the checker itself: a register and a set of integers.

use super::Specification;
use std::collections::BTreeSet;

/// An integer register, initially 0.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Register(pub i64);

/// A register operation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RegisterOp {
    /// Reads the value.
    Read,
    /// Writes a value.
    Write(i64),
}

/// What a register operation returns.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RegisterRet {
    /// A read's value.
    Value(i64),
    /// A write's acknowledgement.
    Done,
}

impl Specification for Register {
    type Op = RegisterOp;
    type Ret = RegisterRet;

    fn apply(&mut self, op: &RegisterOp) -> RegisterRet {
        match *op {
            RegisterOp::Read => RegisterRet::Value(self.0),
            RegisterOp::Write(v) => {
                self.0 = v;
                RegisterRet::Done
            }
        }
    }

    fn observes(op: &RegisterOp, ret: &RegisterRet, other: &RegisterOp) -> bool {
        matches!((op, ret, other), (RegisterOp::Read, RegisterRet::Value(v), RegisterOp::Write(w)) if v == w)
    }
}

/// A set of integers, initially empty.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct IntSet(pub BTreeSet<u32>);

/// A set operation; each returns a `bool`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SetOp {
    /// Adds an element; true when it was absent.
    Insert(u32),
    /// Removes an element; true when it was present.
    Remove(u32),
    /// True when the element is present.
    Contains(u32),
}

impl Specification for IntSet {
    type Op = SetOp;
    type Ret = bool;

    fn apply(&mut self, op: &SetOp) -> bool {
        match *op {
            SetOp::Insert(x) => self.0.insert(x),
            SetOp::Remove(x) => self.0.remove(&x),
            SetOp::Contains(x) => self.0.contains(&x),
        }
    }

    fn observes(op: &SetOp, ret: &bool, other: &SetOp) -> bool {
        match (op, other) {
            (SetOp::Contains(x) | SetOp::Remove(x), SetOp::Insert(y)) => *ret && x == y,
            _ => false,
        }
    }
}
