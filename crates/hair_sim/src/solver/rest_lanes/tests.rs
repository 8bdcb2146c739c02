use super::*;

#[test]
fn every_row_holds_the_rest_shape_strand_by_strand() {
    // 70 strands: a whole block and a part of one.
    let n = 3;
    let positions: Vec<Vec3> = (0..70 * n)
        .map(|i| Vec3::new(i as f32, (i / n) as f32 * 0.5, 1.0 + (i % n) as f32 * (1.0 + i as f32 * 0.01)))
        .collect();
    let rest = RestShape::new(positions, n).unwrap();
    let mut lanes = RestLanes::new(&rest);
    lanes.set_root(65, Vec3::new(-1.0, -2.0, -3.0));
    for strand in 0..70 {
        for j in 0..n {
            let i = strand * n + j;
            let position = if i == 65 * n { Vec3::new(-1.0, -2.0, -3.0) } else { rest.positions[i] };
            for c in 0..3 {
                assert_eq!(lanes.row(strand, j, Row::Position(c))[0], position[c]);
                assert_eq!(lanes.row(strand, j, Row::Direction(c))[0], rest.local_directions[i][c]);
            }
            assert_eq!(lanes.row(strand, j, Row::Length)[0], rest.lengths[i]);
            // Lane `l` of a row is strand `strand + l`, within the block.
            let row = lanes.row(strand, j, Row::Length);
            assert_eq!(row.len(), MAX_LANES - strand % MAX_LANES);
            for (l, &length) in row.iter().enumerate() {
                let expected = if strand + l < 70 { rest.lengths[(strand + l) * n + j] } else { 0.0 };
                assert_eq!(length, expected);
            }
        }
    }
}
