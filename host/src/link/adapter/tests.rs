//! Tests of the parent module (`adapter.rs`).

use super::*;

#[test]
fn every_message_parses_and_bad_values_are_named() {
    assert_eq!(parse_line(br#"{"type":"hello","v":1,"client":"t"}"#), Ok(ClientMsg::Hello { v: 1, client: "t".into() }));
    assert_eq!(
        parse_line(br#"{"type":"odometry","x":1.5,"y":-2,"yaw":0.5}"#),
        Ok(ClientMsg::Odometry(Odometry { x: 1.5, y: -2.0, yaw: 0.5, blocked: false }))
    );
    let ClientMsg::Scan(s) = parse_line(
        br#"{"type":"scan","angle_min":-3.14,"angle_increment":0.01,"range_min":0.1,"range_max":30,"ranges":[1,null,"inf","-inf"]}"#,
    )
    .unwrap() else {
        panic!("a scan")
    };
    assert_eq!(s.ranges[0], 1.0);
    assert!(s.ranges[1].is_nan());
    assert_eq!(s.ranges[2..], [f32::INFINITY, f32::NEG_INFINITY]);
    assert_eq!(parse_line(br#"{"type":"detection"}"#), Ok(ClientMsg::Detection(Detection { position: None })));
    assert_eq!(parse_line(br#"{"type":"detection","x":1,"y":2}"#), Ok(ClientMsg::Detection(Detection { position: Some([1.0, 2.0]) })));
    assert_eq!(parse_line(br#"{"type":"detection","x":1}"#).unwrap_err().to_string(), "detection needs both x and y, or neither");
    assert_eq!(
        parse_line(br#"{"type":"odometry","x":1e6,"y":0,"yaw":0}"#).unwrap_err().to_string(),
        "odometry.x = 1000000 is out of range (|x| <= 30000 m)"
    );
    assert_eq!(
        parse_line(br#"{"type":"scan","angle_min":0,"angle_increment":0,"range_min":0,"range_max":1,"ranges":[1]}"#).unwrap_err().code(),
        "bad_value"
    );
    assert_eq!(
        parse_line(br#"{"type":"scan","angle_min":0,"angle_increment":0.1,"range_min":0,"range_max":1,"ranges":[1,-2]}"#)
            .unwrap_err()
            .to_string(),
        "scan.ranges[1] = -2 is negative"
    );
    assert_eq!(parse_line(br#"[1,2]"#), Err(AdapterError::NotAMessage));
    assert_eq!(parse_line(br#"{"type":"teleport"}"#).unwrap_err().code(), "unknown_type");
    assert_eq!(parse_line(br#"{"type":"odometry","x":"1","y":0,"yaw":0}"#).unwrap_err().code(), "bad_field");
    assert_eq!(parse_line(b"{\"type\":\"odometry\",\"x\":NaN}").unwrap_err().code(), "bad_json");
}
