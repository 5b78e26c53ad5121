//! The right-hand side of an ODE for the integrator, which may also give its Jacobian to the
//! linearly implicit steps (RODAS4).

/// A right-hand side `ẏ = f(t, y)` that may also give its Jacobian `∂f/∂y` (for the
/// linearly implicit steps); any closure `FnMut(t, y, dy) -> Result<(), E>` is one without.
pub trait OdeSystem<E> {
    /// `f(t, y)` into `dy`.
    fn rhs(&mut self, t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), E>;

    /// `∂f/∂y` at `(t, y)`, column-major into `jac` (`n × n`), or `false` (the integrator
    /// then takes it by forward differences of [`Self::rhs`]). None by default.
    fn jacobian(&mut self, _t: f64, _y: &[f64], _jac: &mut [f64]) -> bool {
        false
    }
}

impl<E, F: FnMut(f64, &[f64], &mut [f64]) -> Result<(), E> + ?Sized> OdeSystem<E> for F {
    #[inline]
    fn rhs(&mut self, t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), E> {
        self(t, y, dy)
    }
}
