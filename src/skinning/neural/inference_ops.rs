//! ELU and softmax for the forward pass, without libm's `expf`: its calls were an eighth of a
//! scan's build in `perf` (and below about -103.97 it takes an error-reporting slow path). The
//! exponential here is a polynomial the compiler vectorizes, within a few units in the last
//! place of `expf` where the ELU and softmax read it (arguments at or below zero); the golden
//! replay's tolerances allow a CPU that rounds differently. With gradients tracked (training)
//! candle's own ops run, whose backward passes these lack.

use candle_core::{CpuStorage, CustomOp1, Layout, Shape, Tensor, D};

type CResult<T> = candle_core::Result<T>;

/// Below this, exp is under the smallest normal f32 and taken as zero.
const EXP_FLOOR: f32 = -87.0;

/// 1.5 * 2^23: added to a float of magnitude under 2^22, it leaves that float rounded to an
/// integer in the low bits of its mantissa.
const ROUNDING: f32 = 12_582_912.0;

/// e^v for v <= 0 (larger v is taken as 0): e^v = 2^n e^r with n = round(v log2 e) and
/// |r| <= ln 2 / 2, e^r by Cephes' `expf` polynomial, 2^n written into the exponent bits.
/// n is rounded by adding `ROUNDING` and read from the sum's bits: `floor` and an `as i32`
/// cast (which saturates, so LLVM checks each lane apart) kept the loop half scalar, four
/// times slower over a buffer (a scratch timing of 4M values, printed; the same values).
#[inline]
fn exp_nonpositive(v: f32) -> f32 {
    const LN2_HIGH: f32 = 0.693_359_4;
    const LN2_LOW: f32 = -2.121_944_4e-4;
    let x = v.clamp(EXP_FLOOR, 0.0);
    let rounded = x * std::f32::consts::LOG2_E + ROUNDING;
    let n = rounded - ROUNDING;
    let r = x - n * LN2_HIGH - n * LN2_LOW;
    let p = 1.987_569_1e-4_f32;
    let p = p.mul_add(r, 1.398_199_9e-3);
    let p = p.mul_add(r, 8.333_452e-3);
    let p = p.mul_add(r, 4.166_579_6e-2);
    let p = p.mul_add(r, 1.666_666_5e-1);
    let p = p.mul_add(r, 0.5);
    let er = p.mul_add(r * r, r) + 1.0;
    // n is within [-126, 0]: its biased exponent, n + 127, is that of a normal float.
    let exponent = rounded
        .to_bits()
        .wrapping_sub(ROUNDING.to_bits())
        .wrapping_add(127);
    let scale = f32::from_bits(exponent << 23);
    if v < EXP_FLOOR {
        0.0
    } else {
        er * scale
    }
}

/// ELU with alpha 1, as candle computes it: v when v's sign is positive, else exp(v) - 1.
#[inline]
fn elu_value(v: f32) -> f32 {
    if v.is_sign_positive() {
        v
    } else {
        exp_nonpositive(v) - 1.0
    }
}

/// An elementwise map over a contiguous f32 tensor, its function known at compile time so that
/// the loop is vectorized.
#[derive(Clone, Copy)]
enum Map {
    Elu,
    Exp,
}

impl CustomOp1 for Map {
    fn name(&self) -> &'static str {
        match self {
            Map::Elu => "elu",
            Map::Exp => "exp",
        }
    }

    fn cpu_fwd(&self, storage: &CpuStorage, layout: &Layout) -> CResult<(CpuStorage, Shape)> {
        let (CpuStorage::F32(values), Some((start, end))) = (storage, layout.contiguous_offsets())
        else {
            candle_core::bail!("{} takes a contiguous f32 tensor", self.name())
        };
        let values = &values[start..end];
        let mapped = match self {
            Map::Elu => values.iter().map(|&v| elu_value(v)).collect(),
            Map::Exp => values.iter().map(|&v| exp_nonpositive(v)).collect(),
        };
        Ok((CpuStorage::F32(mapped), layout.shape().clone()))
    }
}

/// Whether the fast maps apply: an f32 tensor on the CPU whose gradient nobody tracks.
fn fast(x: &Tensor) -> bool {
    x.dtype() == candle_core::DType::F32 && x.device().is_cpu() && !x.track_op()
}

fn map(x: &Tensor, map: Map) -> CResult<Tensor> {
    x.contiguous()?.apply_op1_no_bwd(&map)
}

/// `x.elu(1.0)`.
pub(crate) fn elu(x: &Tensor) -> CResult<Tensor> {
    if fast(x) {
        map(x, Map::Elu)
    } else {
        x.elu(1.0)
    }
}

/// `candle_nn::ops::softmax(x, D::Minus1)`: the same steps, the exponential above.
pub(crate) fn softmax_last(x: &Tensor) -> CResult<Tensor> {
    if !fast(x) {
        return candle_nn::ops::softmax(x, D::Minus1);
    }
    let max = x.max_keepdim(D::Minus1)?;
    let numerator = map(&x.broadcast_sub(&max)?, Map::Exp)?;
    let denominator = numerator.sum_keepdim(D::Minus1)?;
    numerator.broadcast_div(&denominator)
}

#[cfg(test)]
mod tests {
    use super::*;
    use candle_core::Device;

    /// |a - b| in units of b's last place (the spacing of f32 at b's magnitude).
    fn ulps(a: f32, b: f32) -> f32 {
        let spacing = f32::from_bits(b.abs().max(f32::MIN_POSITIVE).to_bits() + 1) - b.abs();
        (a - b).abs() / spacing.max(f32::MIN_POSITIVE)
    }

    #[test]
    fn the_exponential_is_within_two_units_in_the_last_place_of_expf() {
        let mut worst = 0.0f32;
        for i in 0..=2_000_000 {
            let v = -87.0 * i as f32 / 2_000_000.0;
            worst = worst.max(ulps(exp_nonpositive(v), v.exp()));
        }
        assert!(worst <= 2.0, "{worst} units in the last place");
        assert_eq!(exp_nonpositive(0.0), 1.0);
        assert_eq!(exp_nonpositive(-0.0), 1.0);
        assert_eq!(exp_nonpositive(-1e30), 0.0);
        assert_eq!(exp_nonpositive(f32::NEG_INFINITY), 0.0);
    }

    fn values(t: &Tensor) -> Vec<f32> {
        t.flatten_all().unwrap().to_vec1().unwrap()
    }

    #[test]
    fn elu_and_softmax_match_candles() {
        let mut v: Vec<f32> = vec![
            -1e30, -200.0, -104.0, -100.0, -87.5, -20.0, -1.5, -1e-8, -0.0, 0.0,
        ];
        v.extend([1e-8, 0.7, 30.0, 88.0, 1e30]);
        let x = Tensor::from_vec(v.clone(), (1, v.len()), &Device::Cpu).unwrap();
        for (a, b) in values(&elu(&x).unwrap())
            .iter()
            .zip(values(&x.elu(1.0).unwrap()))
        {
            assert!(
                (a - b).abs() <= 2.0 * f32::EPSILON * b.abs().max(1.0),
                "{a} against {b}"
            );
        }
        let scores: Vec<f32> = (0..64).map(|i| (i as f32 - 40.0) * 9.1).collect();
        let s = Tensor::from_vec(scores, (4, 16), &Device::Cpu).unwrap();
        let ours = values(&softmax_last(&s).unwrap());
        let theirs = values(&candle_nn::ops::softmax(&s, D::Minus1).unwrap());
        for (a, b) in ours.iter().zip(&theirs) {
            assert!(
                (a - b).abs() <= 1e-37 + 4.0 * f32::EPSILON * b,
                "{a} against {b}"
            );
        }
        let rows: Vec<f32> = ours.chunks(16).map(|r| r.iter().sum()).collect();
        assert!(rows.iter().all(|s| (s - 1.0).abs() < 1e-6), "{rows:?}");
    }

    #[test]
    fn a_tracked_tensor_takes_candles_ops_and_keeps_its_gradient() {
        let v = candle_core::Var::new(&[[-2.0f32, 0.5]], &Device::Cpu).unwrap();
        let y = elu(v.as_tensor()).unwrap().sum_all().unwrap();
        let grads = y.backward().unwrap();
        let g: Vec<f32> = grads
            .get(&v)
            .unwrap()
            .flatten_all()
            .unwrap()
            .to_vec1()
            .unwrap();
        assert!((g[0] - (-2.0f32).exp()).abs() < 1e-6 && (g[1] - 1.0).abs() < 1e-6);
    }
}
