#[test]
fn dump() {
    use std::cell::Cell;
    for a in [0.01f64, 0.08, 0.2, 0.5, 1.2, 3.0] {
        let mut hist = [0u32; 12];
        for i in 0..1000 {
            let u = (i as f64 + 0.5) / 1000.0;
            let y = u * hyperslice::render::lights::cap_integral(a);
            let n = Cell::new(0);
            let f = |t: f64| {
                n.set(n.get() + 1);
                (
                    hyperslice::render::lights::cap_integral(t) - y,
                    2.0 * t.sin().powi(2),
                )
            };
            hyperslice::render::sampling::safeguarded_newton(
                f,
                (1.5 * y).cbrt().clamp(0.0, a),
                (0.0, a),
                1e-15 * a,
            );
            hist[n.get().min(11)] += 1;
        }
        println!("a={a} {hist:?}");
    }
}
