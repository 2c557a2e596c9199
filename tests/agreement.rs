//! Property: after quiescence every cache answers exactly what a brute-force scan over all inserted
//! records answers — the same valid set, the same interpolated irradiance (to 1e-5 relative) — and
//! so the six schemes agree with each other.
#![cfg(not(checker))]

mod common;

use common::{for_each_scheme, w, SchemeCheck, SCHEMES};
use glam::Vec3;
use proptest::prelude::*;
use wfic::cache::{CacheConfig, CacheHandle, IrradianceCache};
use wfic::ic::{self, Record};
use wfic::research::BruteForce;

fn unit(v: Vec3) -> Vec3 {
    let n = v.normalize_or_zero();
    if n == Vec3::ZERO {
        Vec3::Z
    } else {
        n
    }
}

fn vec3(lo: f32, hi: f32) -> impl Strategy<Value = Vec3> {
    (lo..hi, lo..hi, lo..hi).prop_map(|(x, y, z)| Vec3::new(x, y, z))
}

/// Normals: often one of a few shared directions (so records and queries agree), sometimes any.
fn normal() -> impl Strategy<Value = Vec3> {
    prop_oneof![
        2 => Just(Vec3::Z),
        2 => prop::sample::select(common::AXES.to_vec()),
        1 => vec3(-1.0, 1.0).prop_map(unit),
    ]
}

fn record() -> impl Strategy<Value = Record> {
    let position = prop_oneof![vec3(0.0, 4.0), vec3(1.5, 2.5)];
    (
        position,
        normal(),
        vec3(0.0, 5.0),
        0.05f32..1.5,
        vec3(-0.5, 0.5),
        vec3(-0.5, 0.5),
    )
        .prop_map(|(p, n, e, r, gt, gr)| {
            Record::new(p, n, e, r).with_gradients([gt, gt * 0.5, -gt], [gr, -gr, gr * 0.25])
        })
}

/// A query near one of the records (when there are any) or anywhere in the box.
fn queries(records: &[Record]) -> impl Strategy<Value = Vec<(Vec3, Vec3)>> {
    let anchors: Vec<(Vec3, Vec3)> = records.iter().map(|r| (r.position, r.normal)).collect();
    let near = if anchors.is_empty() {
        vec![(Vec3::splat(2.0), Vec3::Z)]
    } else {
        anchors
    };
    let query = prop_oneof![
        2 => (prop::sample::select(near), vec3(-0.3, 0.3), vec3(-0.2, 0.2))
            .prop_map(|((p, n), dp, dn)| (p + dp, unit(n + dn))),
        1 => (vec3(-0.5, 4.5), normal()),
    ];
    prop::collection::vec(query, 1..24)
}

fn case() -> impl Strategy<Value = (f32, Vec<Record>, Vec<(Vec3, Vec3)>)> {
    (
        prop::sample::select(vec![0.15f32, 0.3, 0.6, 1.2]),
        prop::collection::vec(record(), 0..60),
    )
        .prop_flat_map(|(a, records)| {
            let q = queries(&records);
            (Just(a), Just(records), q)
        })
}

fn close(got: Vec3, want: Vec3) -> bool {
    (got - want)
        .abs()
        .cmple(want.abs().max(Vec3::splat(1e-2)) * 1e-5)
        .all()
}

struct Agree<'a> {
    records: &'a [Record],
    queries: &'a [(Vec3, Vec3)],
    oracle: &'a BruteForce,
    answers: Vec<(&'static str, Vec<Option<Vec3>>)>,
}

impl SchemeCheck for Agree<'_> {
    fn check<C: IrradianceCache>(&mut self, mut cache: C) {
        let scheme = cache.scheme().name();
        let frame = cache.frame();
        let mut writer = frame.handle_for(w(0));
        for r in self.records {
            writer.insert(*r).expect("valid record refused");
        }
        drop(writer);
        frame.close();
        assert_eq!(
            cache.stats().records,
            self.records.len(),
            "{scheme}: record count"
        );

        let a = cache.config().accuracy();
        let frame = cache.frame();
        let mut reader = frame.handle_for(w(1));
        let mut answers = Vec::new();
        for &(p, n) in self.queries {
            let got = reader.lookup(p, n);
            let want = self.oracle.lookup(p, n, None);
            match (got, want) {
                (None, None) => {}
                (Some(g), Some(o)) => {
                    assert!(
                        close(g.irradiance, o.irradiance),
                        "{scheme}: at {p} {n} got {} want {}",
                        g.irradiance,
                        o.irradiance
                    );
                    assert_eq!(g.records, o.records, "{scheme}: valid count at {p}");
                }
                (g, o) => panic!("{scheme}: at {p} {n} got {g:?}, oracle {o:?}"),
            }
            answers.push(got.map(|g| g.irradiance));

            // The same valid set: ids are (worker 0, insertion index) in every scheme.
            let mut found = Vec::new();
            reader.valid_records(p, n, &mut found);
            let mut ids: Vec<u64> = found.iter().map(|r| r.id().seq()).collect();
            ids.sort_unstable();
            let want_ids: Vec<u64> = (0..self.records.len() as u64)
                .filter(|&i| ic::valid_weight(&self.records[i as usize], p, n, a).is_some())
                .collect();
            assert_eq!(ids, want_ids, "{scheme}: valid set at {p} {n}");
            assert!(found.iter().all(Record::is_intact), "{scheme}: torn record");
        }
        drop(reader);
        frame.close();
        self.answers.push((scheme, answers));
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 128, ..ProptestConfig::default() })]

    #[test]
    fn every_cache_answers_like_a_brute_force_scan((a, records, queries) in case()) {
        let config = CacheConfig::new(Vec3::ZERO, Vec3::splat(4.0), a).unwrap();
        let mut oracle = BruteForce::new(config);
        for r in &records {
            oracle.insert(*r).unwrap();
        }
        let mut agree = Agree { records: &records, queries: &queries, oracle: &oracle, answers: Vec::new() };
        for_each_scheme(config, &mut agree);

        // And with each other.
        prop_assert_eq!(agree.answers.len(), SCHEMES.len());
        let (first, reference) = &agree.answers[0];
        for (scheme, answers) in &agree.answers[1..] {
            for (x, y) in reference.iter().zip(answers) {
                match (x, y) {
                    (None, None) => {}
                    (Some(x), Some(y)) => prop_assert!(close(*y, *x), "{} vs {}: {} vs {}", scheme, first, y, x),
                    _ => prop_assert!(false, "{} vs {} disagree on a hit", scheme, first),
                }
            }
        }
    }
}

/// The generator reaches the interesting cases: misses, single hits and blends of several records
/// (otherwise the property above would be vacuous).
#[test]
fn the_property_sees_misses_and_blends() {
    use proptest::strategy::ValueTree;
    let mut runner = proptest::test_runner::TestRunner::deterministic();
    let (mut misses, mut singles, mut blends) = (0, 0, 0);
    for _ in 0..64 {
        let (a, records, queries) = case().new_tree(&mut runner).unwrap().current();
        let config = CacheConfig::new(Vec3::ZERO, Vec3::splat(4.0), a).unwrap();
        let mut oracle = BruteForce::new(config);
        records.iter().for_each(|r| oracle.insert(*r).unwrap());
        for (p, n) in queries {
            match oracle.lookup(p, n, None).map(|i| i.records) {
                None => misses += 1,
                Some(1) => singles += 1,
                Some(_) => blends += 1,
            }
        }
    }
    assert!(
        misses > 20 && singles > 20 && blends > 20,
        "{misses} {singles} {blends}"
    );
}
