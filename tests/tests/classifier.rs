//! The int8 classifier inside the controller: a model blob is validated before use, scans without
//! labels are labelled by the network, and the result is deterministic.

use firmware::classifier::{ModelError, WORK_PER_CLASSIFY};
use firmware::scan::BeamLabel;
use firmware::{BinaryAngle, Command, Config, Controller, Inputs, Pose2, ScanInput};
use host::learn::model::{quantise, FloatInputs, FloatModel};

fn blob(seed: u64) -> &'static [u8] {
    let model = FloatModel::random(seed);
    Box::leak(quantise(&model, &[FloatInputs::zeros()]).into_boxed_slice())
}

fn ranges(t: u32) -> Vec<u16> {
    (0..897u32).map(|i| 1_000 + ((i * 37 + t * 11) % 4_000) as u16).collect()
}

fn run(ctrl: &mut Controller, ticks: u32) -> Vec<(firmware::Outputs, Vec<BeamLabel>)> {
    (0..ticks)
        .map(|t| {
            let r = ranges(t);
            let inputs = Inputs {
                pose: Pose2::from_f64(25.0 + t as f64 * 0.05, 25.0, 0.1 * t as f64),
                scan: Some(ScanInput {
                    angle_min: BinaryAngle::HALF,
                    angle_increment: BinaryAngle::from_fraction(1, 897),
                    ranges_mm: &r,
                    labels: None,
                    range_min_mm: 100,
                    range_max_mm: 30_000,
                }),
                command: (t == 0).then_some(Command::Start),
                ..Inputs::default()
            };
            let o = ctrl.tick(t as u64 * 200_000, &inputs);
            (o, ctrl.beams().labels.to_vec())
        })
        .collect()
}

#[test]
fn scans_without_labels_are_labelled_by_the_installed_model() {
    let mut c = Box::new(Controller::new(Config::DEFAULT));
    // Without a model every beam stays unlabelled and the stage costs nothing.
    let out = run(&mut c, 2);
    assert!(out[1].1.iter().all(|&l| l == BeamLabel::Unlabelled));
    assert_eq!(out[1].0.status.cost.classify, 0);

    c.set_model(blob(7)).expect("a valid blob");
    let out = run(&mut c, 12);
    let last = &out.last().unwrap();
    assert_eq!(last.0.status.cost.classify, WORK_PER_CLASSIFY);
    let map = last.1.iter().filter(|&&l| l == BeamLabel::Map).count();
    let non = last.1.iter().filter(|&&l| l == BeamLabel::NonMap).count();
    assert_eq!(map + non, 897, "every valid beam gets a label");
    assert!(map > 0 && non > 0, "random weights give both classes ({map} map, {non} non-map)");
}

#[test]
fn a_corrupt_model_is_refused_and_the_previous_one_stays() {
    let mut c = Box::new(Controller::new(Config::DEFAULT));
    let good = blob(3);
    c.set_model(good).unwrap();
    let mut bad = good.to_vec();
    let mid = bad.len() / 2;
    bad[mid] ^= 0x40;
    let bad: &'static [u8] = Box::leak(bad.into_boxed_slice());
    assert!(matches!(c.set_model(bad), Err(ModelError::ChecksumMismatch { .. })));
    let truncated: &'static [u8] = &good[..good.len() - 10];
    assert!(c.set_model(truncated).is_err());
    assert!(c.set_model(&[]).is_err());
    // The good model still classifies.
    let out = run(&mut c, 2);
    assert_eq!(out[1].0.status.cost.classify, WORK_PER_CLASSIFY);
}

#[test]
fn the_classifier_is_deterministic_inside_the_controller() {
    let mut a = Box::new(Controller::new(Config::DEFAULT));
    let mut b = Box::new(Controller::new(Config::DEFAULT));
    let m = blob(11);
    a.set_model(m).unwrap();
    b.set_model(m).unwrap();
    assert_eq!(run(&mut a, 15), run(&mut b, 15));
}

#[test]
fn the_embedded_model_validates_and_runs() {
    let mut c = Box::new(Controller::new(Config::DEFAULT));
    c.set_model(firmware::classifier::EMBEDDED_MODEL).expect("the committed model blob validates");
    let out = run(&mut c, 3);
    assert_eq!(out[2].0.status.cost.classify, WORK_PER_CLASSIFY);
    assert!(out[2].1.iter().all(|&l| l != BeamLabel::Unlabelled), "every valid beam labelled");
}
