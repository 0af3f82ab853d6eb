//! Modbus TCP temperature modules (tokio-modbus): registers polled, scaled and checked;
//! optionally the applied offset written to a holding register of the first module.
//!
//! A register value outside its plausible range (modules report 0x7FFF/0x8000 for an open
//! sensor) raises an alarm naming module, register, value and range, and is handed to the
//! engine as NaN, which freezes the axes reading that channel. A lost connection is
//! retried with exponential back-off.

use super::InputTx;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Duration;

use tokio::sync::watch;
use tokio_modbus::prelude::*;

use crate::config::{
    FlagTable, ModbusHeartbeat, ModbusInput, ModbusModule, ModbusPosition, ModbusPulseOutput,
    ModbusStopOutput, RegisterMap, RegisterTable,
};
use crate::cycle::{Clock, InputMsg, OffsetOut};

/// Converts a register word into the engineering value.
///
/// # Formula
/// r = word as i16 (signed) or u16;  value = r·scale + offset, valid when raw_min ≤ r ≤ raw_max
/// # Source
/// Modbus application protocol V1.1b3 §4.2 (16-bit big-endian registers) [STANDARD];
/// linear scaling as in temperature-module manuals [CONVENTION, docs/service.md]
pub fn decode_register(word: u16, map: &RegisterMap) -> Result<f64, String> {
    let r: i32 = if map.signed {
        i32::from(word as i16)
    } else {
        i32::from(word)
    };
    if r < map.raw_min || r > map.raw_max {
        return Err(format!(
            "register {} ({:?}) = {r}: outside the plausible range {}…{} (sensor open or shorted?)",
            map.address, map.table, map.raw_min, map.raw_max
        ));
    }
    Ok(f64::from(r) * map.scale + map.offset)
}

/// Converts an offset into a signed register word.
///
/// # Formula
/// counts = round(offset_um / um_per_count), written as i16 two's complement
/// # Source
/// Modbus application protocol V1.1b3 §6.6 (Write Single Register) [STANDARD]; the
/// absolute-value, fixed-point encoding is this service's [CONVENTION, docs/service.md]
pub fn encode_offset(offset_um: f64, um_per_count: f64) -> Result<u16, String> {
    let c = (offset_um / um_per_count).round();
    if !(c.is_finite() && c >= f64::from(i16::MIN) && c <= f64::from(i16::MAX)) {
        return Err(format!(
            "offset {offset_um} µm = {c} counts of {um_per_count} µm: outside the register range −32768…32767"
        ));
    }
    Ok((c as i16) as u16)
}

/// Converts the words of a position register into mm.
///
/// # Formula
/// r = word as i16 (one word) or (high·65536 + low) as i32 (two words, high first);
/// position_mm = r·mm_per_count + offset_mm
/// # Source
/// Modbus application protocol V1.1b3 §4.2 (16-bit big-endian registers) [STANDARD]; the
/// high-word-first i32 and the linear scale are this service's [CONVENTION,
/// docs/service.md]
pub fn decode_position(words: &[u16], p: &ModbusPosition) -> Result<f64, String> {
    let r: i64 = match (p.words, words) {
        (1, [w, ..]) => i64::from(*w as i16),
        (2, [hi, lo, ..]) => i64::from(((u32::from(*hi) << 16) | u32::from(*lo)) as i32),
        _ => {
            return Err(format!(
                "position register {} of axis {}: {} word(s) read, {} expected",
                p.address,
                p.axis,
                words.len(),
                p.words
            ))
        }
    };
    Ok(r as f64 * p.mm_per_count + p.offset_mm)
}

/// The two words (high first) of a cumulative pulse count, as an i32.
///
/// # Formula
/// high = (total as i32 as u32) >> 16, low = (total as i32 as u32) & 0xFFFF
/// # Source
/// Modbus application protocol V1.1b3 §6.12 (Write Multiple Registers) [STANDARD];
/// high word first is this service's [CONVENTION, docs/service.md]
pub fn encode_pulse_total(total: i64) -> Result<[u16; 2], String> {
    let t = i32::try_from(total).map_err(|_| {
        format!("pulse total {total} outside the i32 range of the counter registers")
    })?;
    let u = t as u32;
    Ok([(u >> 16) as u16, (u & 0xFFFF) as u16])
}

/// The cumulative pulse count of two words, high first.
pub fn decode_pulse_total(words: [u16; 2]) -> i64 {
    i64::from(((u32::from(words[0]) << 16) | u32::from(words[1])) as i32)
}

/// Reads `n` registers of `table` from `address`, the words as the device answered them
/// (their count is the caller's to check). Through `Client::call` rather than
/// `read_input_registers` / `read_holding_registers`, which `debug_assert` that the device
/// answered `n` words: a device answering another count (a valid frame with byte count 0
/// or 4) panicked the adapter's task in a debug build, and in a release build the register
/// poll skipped the reading without an alarm.
async fn read_registers(
    ctx: &mut client::Context,
    table: RegisterTable,
    address: u16,
    n: u16,
) -> tokio_modbus::Result<Vec<u16>> {
    let request = match table {
        RegisterTable::Input => Request::ReadInputRegisters(address, n),
        RegisterTable::Holding => Request::ReadHoldingRegisters(address, n),
    };
    // `call` refuses a response of another function; nothing else can come back.
    ctx.call(request).await.map(|r| {
        r.map(|response| match response {
            Response::ReadInputRegisters(w) | Response::ReadHoldingRegisters(w) => w,
            _ => Vec::new(),
        })
    })
}

/// Everything the Modbus adapter needs.
pub struct ModbusParts {
    /// The configuration.
    pub cfg: ModbusInput,
    /// Engine channels in order.
    pub channels: Vec<String>,
    /// Axis names in order.
    pub axes: Vec<String>,
    /// The service clock.
    pub clock: Clock,
    /// To the cycle.
    pub tx: InputTx,
    /// From the cycle.
    pub offsets: watch::Receiver<OffsetOut>,
    /// The cycle's step count (`Cycle::alive`), for the heartbeat output.
    pub alive: Arc<AtomicU64>,
}

/// Checks that every mapped channel and the offset axis exist; returns the channel index
/// of every register, per module.
pub fn resolve(
    cfg: &ModbusInput,
    channels: &[String],
    axes: &[String],
) -> crate::error::Result<Vec<Vec<u16>>> {
    let mut out = Vec::new();
    for (i, m) in cfg.modules.iter().enumerate() {
        let mut v = Vec::new();
        for (j, r) in m.registers.iter().enumerate() {
            let c = channels
                .iter()
                .position(|c| c == &r.channel)
                .ok_or_else(|| {
                    crate::error::invalid(
                        format!("input.modules[{i}].registers[{j}].channel"),
                        &r.channel,
                        format!("an engine channel: {}", channels.join(", ")),
                    )
                })?;
            v.push(c as u16);
        }
        out.push(v);
    }
    if let Some(o) = &cfg.offset_output {
        crate::error::engine_axis("input.offset_output.axis", &o.axis, axes)?;
    }
    if let Some(o) = &cfg.pulse_output {
        crate::error::engine_axis("input.pulse_output.axis", &o.axis, axes)?;
    }
    for (i, p) in cfg.positions.iter().enumerate() {
        crate::error::engine_axis(format!("input.positions[{i}].axis"), &p.axis, axes)?;
    }
    Ok(out)
}

fn send(tx: &InputTx, m: InputMsg) {
    let _ = tx.try_send(m);
}

async fn connect(m: &ModbusModule) -> std::io::Result<client::Context> {
    let addr: SocketAddr = tokio::net::lookup_host((m.host.as_str(), m.port))
        .await?
        .next()
        .ok_or_else(|| std::io::Error::new(std::io::ErrorKind::NotFound, "no address"))?;
    tokio::time::timeout(
        Duration::from_secs(3),
        client::tcp::connect_slave(addr, Slave(m.unit_id)),
    )
    .await
    .map_err(|_| std::io::Error::new(std::io::ErrorKind::TimedOut, "connect timed out"))?
}

/// Runs every module until the task is aborted.
pub async fn run(p: ModbusParts) -> crate::error::Result<()> {
    let index = resolve(&p.cfg, &p.channels, &p.axes)?;
    let offset_axis = p
        .cfg
        .offset_output
        .as_ref()
        .and_then(|o| p.axes.iter().position(|a| a == &o.axis));
    if let Some(o) = &p.cfg.pulse_output {
        let pulse_axis = p.axes.iter().position(|a| a == &o.axis);
        if pulse_axis.is_none_or(|a| p.offsets.borrow().pulse_um.get(a).is_none_or(|u| *u <= 0.0)) {
            // Nothing is written for it; said once, not per poll.
            send(
                &p.tx,
                InputMsg::RaiseAlarm {
                    key: PULSE_KEY.into(),
                    message: format!(
                        "input.pulse_output.axis = {:?}: the axis is not applied as pulses (engine apply kind = \"pulses\" expected); no pulses are written",
                        o.axis
                    ),
                },
            );
        }
    }
    // A JoinSet aborts the module tasks when this future is dropped (service stop).
    let mut tasks = tokio::task::JoinSet::new();
    for (i, (m, idx)) in p.cfg.modules.iter().cloned().zip(index).enumerate() {
        let out = if i == 0 {
            p.cfg.offset_output.clone().zip(offset_axis)
        } else {
            None
        };
        let flags = (i == 0
            && (p.cfg.stop_output.is_some()
                || p.cfg.heartbeat.is_some()
                || p.cfg.pulse_output.is_some()
                || !p.cfg.positions.is_empty()))
        .then(|| Flags {
            stop: p.cfg.stop_output.clone(),
            heartbeat: p.cfg.heartbeat.clone(),
            alive: p.alive.clone(),
            pulses: p.cfg.pulse_output.clone().and_then(|o| {
                let a = p.axes.iter().position(|a| a == &o.axis)?;
                Some((o, a))
            }),
            positions: p
                .cfg
                .positions
                .iter()
                .filter_map(|q| Some((q.clone(), p.axes.iter().position(|a| a == &q.axis)?)))
                .collect(),
        });
        tasks.spawn(run_module(
            i,
            m,
            idx,
            p.cfg.clone(),
            out,
            flags,
            p.clock,
            p.tx.clone(),
            p.offsets.clone(),
        ));
    }
    // A module's task that panicked is alarmed (its input would just go silent).
    while let Some(done) = tasks.join_next().await {
        if let Err(e) = done {
            if e.is_panic() {
                super::adapter_panicked(&p.tx, "Modbus", e.into_panic().as_ref());
            }
        }
    }
    Ok(())
}

#[allow(clippy::too_many_arguments)]
async fn run_module(
    i: usize,
    m: ModbusModule,
    index: Vec<u16>,
    cfg: ModbusInput,
    out: Option<(crate::config::ModbusOffsetOutput, usize)>,
    flags: Option<Flags>,
    clock: Clock,
    tx: InputTx,
    mut offsets: watch::Receiver<OffsetOut>,
) {
    let conn_key = format!("modbus.{i}.connection");
    let period = Duration::from_secs_f64(cfg.poll_period_s);
    let mut failures = 0u32;
    let mut held = Held::default();
    let mut flag_state = FlagState::default();
    loop {
        let mut ctx = match connect(&m).await {
            Ok(c) => c,
            Err(e) => {
                failures = failures.saturating_add(1);
                let wait_s = cfg.reconnect.wait_s(failures);
                send(
                    &tx,
                    InputMsg::RaiseAlarm {
                        key: conn_key.clone(),
                        message: format!(
                            "Modbus module {i} at {}:{} (unit {}): {e}; retrying with back-off ({wait_s} s)",
                            m.host, m.port, m.unit_id
                        ),
                    },
                );
                tokio::time::sleep(Duration::from_secs_f64(wait_s)).await;
                continue;
            }
        };
        // A new connection (the device may have restarted): check and write at once.
        held.connected = true;
        flag_state.stop_written = None;
        flag_state.pulses_checked = false;
        // The connection counts (back-off reset, alarm cleared) only once the device has
        // answered: a device that accepts connections but never answers stays one alarm
        // with a growing wait, not an alarm that clears at every connect.
        let mut answered = false;
        let mut tick = tokio::time::interval(period);
        tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        'poll: loop {
            tick.tick().await;
            for (r, &ch) in m.registers.iter().zip(&index) {
                let res = tokio::time::timeout(
                    Duration::from_secs(3),
                    read_registers(&mut ctx, r.table, r.address, 1),
                )
                .await;
                let stamp_s = clock.now_s();
                let key = format!("modbus.{i}.register.{}", r.address);
                if !answered && matches!(res, Ok(Ok(_))) {
                    answered = true;
                    failures = 0;
                    send(
                        &tx,
                        InputMsg::ClearAlarm {
                            key: conn_key.clone(),
                        },
                    );
                }
                match res {
                    Ok(Ok(Ok(words))) => {
                        // A device answering another count of words than asked is a bad
                        // reading (alarmed, NaN), not a poll skipped without a word.
                        let decoded = match words.as_slice() {
                            [w] => decode_register(*w, r),
                            _ => Err(format!(
                                "register {}: {} words answered, 1 expected",
                                r.address,
                                words.len()
                            )),
                        };
                        match decoded {
                            Ok(v) => {
                                send(&tx, InputMsg::ClearAlarm { key });
                                send(
                                    &tx,
                                    InputMsg::Sample {
                                        channel: ch,
                                        raw: v,
                                        stamp_s,
                                    },
                                );
                            }
                            Err(msg) => {
                                send(
                                    &tx,
                                    InputMsg::RaiseAlarm {
                                        key,
                                        message: format!(
                                            "Modbus module {i}, channel {}: {msg}",
                                            r.channel
                                        ),
                                    },
                                );
                                send(
                                    &tx,
                                    InputMsg::Sample {
                                        channel: ch,
                                        raw: f64::NAN,
                                        stamp_s,
                                    },
                                );
                            }
                        }
                    }
                    Ok(Ok(Err(exc))) => send(
                        &tx,
                        InputMsg::RaiseAlarm {
                            key,
                            message: format!(
                                "Modbus module {i}, register {}: exception {exc:?}",
                                r.address
                            ),
                        },
                    ),
                    Ok(Err(e)) => {
                        send(
                            &tx,
                            InputMsg::RaiseAlarm {
                                key: conn_key.clone(),
                                message: format!("Modbus module {i}: {e}; reconnecting"),
                            },
                        );
                        break 'poll;
                    }
                    Err(_) => {
                        send(
                            &tx,
                            InputMsg::RaiseAlarm {
                                key: conn_key.clone(),
                                message: format!(
                                    "Modbus module {i}: no answer within 3 s; reconnecting"
                                ),
                            },
                        );
                        break 'poll;
                    }
                }
            }
            if let Some(f) = &flags {
                if read_positions(&mut ctx, f, &tx).await.is_err() {
                    break 'poll;
                }
            }
            send(&tx, InputMsg::ScanEnd);
            if let Some((o, axis)) = &out {
                let snap = *offsets.borrow_and_update();
                if write_output(&mut ctx, o, *axis, &snap, &mut held, &tx)
                    .await
                    .is_err()
                {
                    break 'poll;
                }
            }
            if let Some(f) = &flags {
                let snap = *offsets.borrow();
                if write_flags(&mut ctx, f, &snap, &mut flag_state, &tx)
                    .await
                    .is_err()
                {
                    break 'poll;
                }
                if let Some((o, axis)) = &f.pulses {
                    if write_pulses(&mut ctx, o, *axis, &snap, &mut flag_state, &tx)
                        .await
                        .is_err()
                    {
                        break 'poll;
                    }
                }
            }
        }
        failures = failures.saturating_add(1);
        tokio::time::sleep(Duration::from_secs_f64(cfg.reconnect.wait_s(failures))).await;
    }
}

/// The stop and heartbeat outputs of the first module.
#[derive(Debug, Clone)]
struct Flags {
    stop: Option<ModbusStopOutput>,
    heartbeat: Option<ModbusHeartbeat>,
    alive: Arc<AtomicU64>,
    /// The pulse counter and its axis.
    pulses: Option<(ModbusPulseOutput, usize)>,
    /// Position registers and their axes.
    positions: Vec<(ModbusPosition, usize)>,
}

#[derive(Debug, Default)]
struct FlagState {
    /// The stop flag last confirmed written (None: write at once).
    stop_written: Option<bool>,
    /// When the stop flag is written again regardless (a device that restarted).
    next_stop_refresh: Option<tokio::time::Instant>,
    /// The heartbeat counter last written.
    beat: u16,
    next_beat: Option<tokio::time::Instant>,
    /// The cycle's step count at the last beat.
    last_alive: u64,
    /// The pulse total the device acknowledged (None: take the cycle's at the first poll).
    pulses_acked: Option<i64>,
    /// A pulse total written whose response has not arrived (the connection failed).
    pulses_pending: Option<i64>,
    /// The counter was read back on this connection.
    pulses_checked: bool,
}

const PULSE_KEY: &str = "modbus.pulse_output";
const PULSE_HELD_KEY: &str = "modbus.pulse_output.held";

/// Reads every position register and hands the positions to the cycle; a refused or
/// implausible read makes the position unknown (NaN: the axes whose law needs it freeze)
/// with an alarm. Err: the connection failed.
async fn read_positions(
    ctx: &mut client::Context,
    f: &Flags,
    tx: &InputTx,
) -> std::result::Result<(), ()> {
    for (p, axis) in &f.positions {
        let n = u16::from(p.words);
        let res = tokio::time::timeout(
            Duration::from_secs(3),
            read_registers(ctx, p.table, p.address, n),
        )
        .await;
        let key = format!("modbus.position.{}", p.axis);
        let pos = match res {
            Ok(Ok(Ok(words))) => decode_position(&words, p),
            Ok(Ok(Err(exc))) => Err(format!(
                "position register {} of axis {}: exception {exc:?}",
                p.address, p.axis
            )),
            Ok(Err(_)) | Err(_) => return Err(()),
        };
        match pos {
            Ok(position_mm) => {
                send(tx, InputMsg::ClearAlarm { key });
                send(
                    tx,
                    InputMsg::Position {
                        axis: *axis as u8,
                        position_mm,
                    },
                );
            }
            Err(msg) => {
                send(
                    tx,
                    InputMsg::RaiseAlarm {
                        key,
                        message: format!("Modbus {msg}; axes reading it are frozen"),
                    },
                );
                send(
                    tx,
                    InputMsg::Position {
                        axis: *axis as u8,
                        position_mm: f64::NAN,
                    },
                );
            }
        }
    }
    Ok(())
}

/// Writes the cumulative infeed-pulse count of a pulse axis when pulses are issued that
/// the device has not acknowledged. A total counts as sent only on the write response
/// (then reported to the cycle, which keeps it in the resume state). On every new
/// connection the counter is read back: a total written whose response was lost counts
/// as acknowledged when the device holds it; any other value (device restarted or
/// overwritten) is alarmed and the total written again. Err: the connection failed.
async fn write_pulses(
    ctx: &mut client::Context,
    o: &ModbusPulseOutput,
    axis: usize,
    snap: &OffsetOut,
    st: &mut FlagState,
    tx: &InputTx,
) -> std::result::Result<(), ()> {
    if axis >= snap.n_axes as usize || snap.pulse_um[axis] <= 0.0 {
        return Ok(());
    }
    let acked = *st.pulses_acked.get_or_insert(snap.pulses_acked[axis]);
    let mut force = false;
    if !st.pulses_checked {
        let read = tokio::time::timeout(
            Duration::from_secs(3),
            read_registers(ctx, RegisterTable::Holding, o.address, 2),
        )
        .await;
        match read {
            Ok(Ok(Ok(w))) if w.len() == 2 => {
                st.pulses_checked = true;
                let held = decode_pulse_total([w[0], w[1]]);
                if held == acked {
                    send(
                        tx,
                        InputMsg::ClearAlarm {
                            key: PULSE_HELD_KEY.into(),
                        },
                    );
                } else if Some(held) == st.pulses_pending {
                    // Written before the connection failed, response lost: it arrived.
                    st.pulses_acked = Some(held);
                    send(
                        tx,
                        InputMsg::PulsesAcked {
                            axis: axis as u8,
                            total: held,
                        },
                    );
                } else {
                    send(
                        tx,
                        InputMsg::RaiseAlarm {
                            key: PULSE_HELD_KEY.into(),
                            message: format!(
                                "Modbus pulse counter {}–{} holds {held}, the device had acknowledged {acked}: device restarted or overwritten; the total is written again (the PLC applies the difference to the count it last applied)",
                                o.address,
                                o.address.wrapping_add(1)
                            ),
                        },
                    );
                    force = true;
                }
                st.pulses_pending = None;
            }
            Ok(Ok(_)) => {
                st.pulses_checked = true;
                send(
                    tx,
                    InputMsg::RaiseAlarm {
                        key: PULSE_HELD_KEY.into(),
                        message: format!(
                            "Modbus pulse counter {}: read-back refused; written again",
                            o.address
                        ),
                    },
                );
                force = true;
            }
            Ok(Err(_)) | Err(_) => return Err(()),
        }
    }
    let acked = st.pulses_acked.unwrap_or(acked);
    let total = snap.pulse_total[axis];
    if total == acked && !force {
        return Ok(());
    }
    let words = match encode_pulse_total(total) {
        Ok(w) => w,
        Err(msg) => {
            send(
                tx,
                InputMsg::RaiseAlarm {
                    key: PULSE_KEY.into(),
                    message: msg,
                },
            );
            return Ok(());
        }
    };
    st.pulses_pending = Some(total);
    let res = tokio::time::timeout(
        Duration::from_secs(3),
        ctx.write_multiple_registers(o.address, &words),
    )
    .await;
    match res {
        Ok(Ok(Ok(()))) => {
            st.pulses_pending = None;
            st.pulses_acked = Some(total);
            send(
                tx,
                InputMsg::PulsesAcked {
                    axis: axis as u8,
                    total,
                },
            );
            send(
                tx,
                InputMsg::ClearAlarm {
                    key: PULSE_KEY.into(),
                },
            );
            Ok(())
        }
        Ok(Ok(Err(exc))) => {
            st.pulses_pending = None;
            send(
                tx,
                InputMsg::RaiseAlarm {
                    key: PULSE_KEY.into(),
                    message: format!(
                        "Modbus pulse counter {}: exception {exc:?}; retrying",
                        o.address
                    ),
                },
            );
            Ok(())
        }
        Ok(Err(_)) | Err(_) => {
            send(
                tx,
                InputMsg::RaiseAlarm {
                    key: PULSE_KEY.into(),
                    message: format!(
                        "Modbus pulse counter {}: no write response; the total is checked and sent again on the next connection",
                        o.address
                    ),
                },
            );
            Err(())
        }
    }
}

const STOP_KEY: &str = "modbus.stop_output";
const BEAT_KEY: &str = "modbus.heartbeat";

/// Writes the stop / feed-hold flag when it changes, on a new connection and every
/// second; counts the heartbeat register up every `period_s` while the cycle steps (a
/// dead cycle stops the heartbeat, so the PLC holds its last offset). Err: the
/// connection failed.
async fn write_flags(
    ctx: &mut client::Context,
    f: &Flags,
    snap: &OffsetOut,
    st: &mut FlagState,
    tx: &InputTx,
) -> std::result::Result<(), ()> {
    let now = tokio::time::Instant::now();
    if let Some(so) = &f.stop {
        let due = st.next_stop_refresh.is_none_or(|t| now >= t);
        if st.stop_written != Some(snap.stop) || due {
            let res = match so.table {
                FlagTable::Coil => ctx.write_single_coil(so.address, snap.stop).await,
                FlagTable::Holding => {
                    ctx.write_single_register(so.address, u16::from(snap.stop))
                        .await
                }
            };
            match res {
                Ok(Ok(())) => {
                    st.stop_written = Some(snap.stop);
                    st.next_stop_refresh = Some(now + Duration::from_secs(1));
                    send(
                        tx,
                        InputMsg::ClearAlarm {
                            key: STOP_KEY.into(),
                        },
                    );
                }
                Ok(Err(exc)) => send(
                    tx,
                    InputMsg::RaiseAlarm {
                        key: STOP_KEY.into(),
                        message: format!(
                            "Modbus stop output ({:?} {}) = {}: exception {exc:?}; retrying",
                            so.table,
                            so.address,
                            u8::from(snap.stop)
                        ),
                    },
                ),
                Err(_) => return Err(()),
            }
        }
    }
    if let Some(h) = &f.heartbeat {
        if st.next_beat.is_none_or(|t| now >= t) {
            st.next_beat = Some(now + Duration::from_secs_f64(h.period_s));
            let a = f.alive.load(Ordering::Acquire);
            if a != st.last_alive {
                st.last_alive = a;
                let beat = st.beat.wrapping_add(1);
                match ctx.write_single_register(h.address, beat).await {
                    Ok(Ok(())) => {
                        st.beat = beat;
                        send(
                            tx,
                            InputMsg::ClearAlarm {
                                key: BEAT_KEY.into(),
                            },
                        );
                    }
                    Ok(Err(exc)) => send(
                        tx,
                        InputMsg::RaiseAlarm {
                            key: BEAT_KEY.into(),
                            message: format!(
                                "Modbus heartbeat register {}: exception {exc:?}; retrying",
                                h.address
                            ),
                        },
                    ),
                    Err(_) => return Err(()),
                }
            }
        }
    }
    Ok(())
}

/// What the offset output knows about the device's register.
#[derive(Debug, Default)]
struct Held {
    /// The offset sequence number last confirmed written.
    written_seq: u64,
    /// The word last confirmed written (what the device should hold).
    word: Option<u16>,
    /// When the register is read back next.
    next_check: Option<tokio::time::Instant>,
    /// A connection was (re)opened since the last write.
    connected: bool,
}

const OUT_KEY: &str = "modbus.offset_output";
const HELD_KEY: &str = "modbus.offset_output.held";

/// Writes the newest valid offset when it is new, on a new connection, or when the
/// device no longer holds the word last written (read back every `refresh_s`: a device
/// that restarted or was overwritten raises `modbus.offset_output.held` and is written
/// again). Err: the connection failed.
async fn write_output(
    ctx: &mut client::Context,
    o: &crate::config::ModbusOffsetOutput,
    axis: usize,
    snap: &OffsetOut,
    held: &mut Held,
    tx: &InputTx,
) -> std::result::Result<(), ()> {
    // Nothing before the axis has a valid offset (no 0 meaning "no value yet").
    if axis >= snap.n_axes as usize || !snap.valid[axis] {
        return Ok(());
    }
    let now = tokio::time::Instant::now();
    let mut force = std::mem::take(&mut held.connected);
    if let Some(want) = held.word {
        if force || held.next_check.is_none_or(|t| now >= t) {
            held.next_check = Some(now + Duration::from_secs_f64(o.refresh_s));
            let read = tokio::time::timeout(
                Duration::from_secs(3),
                read_registers(ctx, RegisterTable::Holding, o.address, 1),
            )
            .await;
            match read {
                Ok(Ok(Ok(w))) if w.first() == Some(&want) => {
                    send(
                        tx,
                        InputMsg::ClearAlarm {
                            key: HELD_KEY.into(),
                        },
                    );
                }
                Ok(Ok(Ok(w))) => {
                    let got = w
                        .first()
                        .map_or("nothing".to_string(), |v| format!("{} counts", *v as i16));
                    send(
                        tx,
                        InputMsg::RaiseAlarm {
                            key: HELD_KEY.into(),
                            message: format!(
                                "Modbus offset register {} holds {got}, expected {} counts ({} µm at {} µm/count): device restarted or overwritten; written again",
                                o.address,
                                want as i16,
                                f64::from(want as i16) * o.um_per_count,
                                o.um_per_count
                            ),
                        },
                    );
                    force = true;
                }
                Ok(Ok(Err(exc))) => {
                    send(
                        tx,
                        InputMsg::RaiseAlarm {
                            key: HELD_KEY.into(),
                            message: format!(
                                "Modbus offset register {}: read-back refused ({exc:?}); written again",
                                o.address
                            ),
                        },
                    );
                    force = true;
                }
                Ok(Err(_)) | Err(_) => return Err(()),
            }
        }
    }
    if snap.seq == held.written_seq && !force {
        return Ok(());
    }
    let word = match encode_offset(snap.offsets_um[axis], o.um_per_count) {
        Ok(w) => w,
        Err(msg) => {
            held.written_seq = snap.seq;
            send(
                tx,
                InputMsg::RaiseAlarm {
                    key: OUT_KEY.into(),
                    message: msg,
                },
            );
            return Ok(());
        }
    };
    match ctx.write_single_register(o.address, word).await {
        Ok(Ok(())) => {
            // Only a confirmed write counts; a failed one is retried with the newest
            // value at the next poll.
            held.written_seq = snap.seq;
            held.word = Some(word);
            if held.next_check.is_none() {
                held.next_check = Some(now + Duration::from_secs_f64(o.refresh_s));
            }
            send(
                tx,
                InputMsg::ClearAlarm {
                    key: OUT_KEY.into(),
                },
            );
            Ok(())
        }
        Ok(Err(exc)) => {
            held.connected = true;
            send(
                tx,
                InputMsg::RaiseAlarm {
                    key: OUT_KEY.into(),
                    message: format!(
                        "Modbus offset write to register {}: exception {exc:?}; retrying",
                        o.address
                    ),
                },
            );
            Ok(())
        }
        Err(e) => {
            held.connected = true;
            send(
                tx,
                InputMsg::RaiseAlarm {
                    key: OUT_KEY.into(),
                    message: format!(
                        "Modbus offset write to register {}: {e}; retrying",
                        o.address
                    ),
                },
            );
            Err(())
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;
    use proptest::prelude::*;

    fn map(signed: bool, scale: f64, offset: f64) -> RegisterMap {
        RegisterMap {
            channel: "t".into(),
            address: 7,
            table: RegisterTable::Input,
            signed,
            scale,
            offset,
            raw_min: if signed { -32767 } else { 0 },
            raw_max: if signed { 32766 } else { 65535 },
        }
    }

    #[test]
    fn two_complement_and_scaling() {
        // 0xFF9C = −100 as i16 → −10.0 °C at 0.1 °C/count.
        assert_eq!(
            decode_register(0xFF9C, &map(true, 0.1, 0.0)).unwrap(),
            -10.0
        );
        assert_eq!(decode_register(215, &map(true, 0.1, 0.0)).unwrap(), 21.5);
        // Unsigned with an offset: 4–20 mA module, 0…65535 → −50…150 °C.
        let m = map(false, 200.0 / 65535.0, -50.0);
        assert!((decode_register(65535, &m).unwrap() - 150.0).abs() < 1e-12);
        // The open-sensor codes are refused.
        assert!(decode_register(0x7FFF, &map(true, 0.1, 0.0))
            .unwrap_err()
            .contains("32767"));
        assert!(decode_register(0x8000, &map(true, 0.1, 0.0)).is_err());
    }

    #[test]
    fn pulse_counter_words_by_hand() {
        // −21 as i32 = 0xFFFF_FFEB: high 0xFFFF, low 0xFFEB.
        assert_eq!(encode_pulse_total(-21).unwrap(), [0xFFFF, 0xFFEB]);
        // 70 000 = 0x0001_1170.
        assert_eq!(encode_pulse_total(70_000).unwrap(), [0x0001, 0x1170]);
        assert_eq!(decode_pulse_total([0xFFFF, 0xFFEB]), -21);
        assert_eq!(decode_pulse_total([0x0001, 0x1170]), 70_000);
        assert!(encode_pulse_total(i64::from(i32::MAX) + 1)
            .unwrap_err()
            .contains("i32"));
    }

    #[test]
    fn position_registers_by_hand() {
        let p = |words: u8, mm_per_count: f64, offset_mm: f64| ModbusPosition {
            axis: "Z".into(),
            address: 2,
            table: RegisterTable::Input,
            words,
            mm_per_count,
            offset_mm,
        };
        // 0xC568 = −15000 as i16 → −15 mm at 0.001 mm/count.
        assert_eq!(
            decode_position(&[0xC568], &p(1, 0.001, 0.0)).unwrap(),
            -15.0
        );
        // 0x0001_86A0 = 100 000 → 100 mm at 0.001 mm/count, + 5 mm.
        assert_eq!(
            decode_position(&[0x0001, 0x86A0], &p(2, 0.001, 5.0)).unwrap(),
            105.0
        );
        // 0xFFFF_FFFF = −1 → −0.5 mm at 0.5 mm/count.
        assert_eq!(
            decode_position(&[0xFFFF, 0xFFFF], &p(2, 0.5, 0.0)).unwrap(),
            -0.5
        );
        assert!(decode_position(&[0x0001], &p(2, 0.001, 0.0)).is_err());
    }

    #[test]
    fn position_and_pulse_keys_are_checked() {
        let cfg = |extra: &str| {
            crate::ServiceConfig::from_toml_str(
                &format!(
                    "[input]\nkind = \"modbus\"\n{extra}\n[[input.modules]]\nhost = \"127.0.0.1\"\nregisters = []\n"
                ),
                "machine.toml",
            )
        };
        let e = cfg("positions = [{ axis = \"Z\", address = 2, words = 3 }]")
            .unwrap_err()
            .to_string();
        assert!(e.contains("input.positions[0].words = 3"), "{e}");
        let e = cfg("positions = [{ axis = \"Z\", address = 2, mm_per_count = 0.0 }]")
            .unwrap_err()
            .to_string();
        assert!(e.contains("input.positions[0].mm_per_count"), "{e}");
        assert!(cfg("pulse_output = { axis = \"Z\", address = 12 }\npositions = [{ axis = \"Z\", address = 2 }]").is_ok());
        let r = resolve(
            &match cfg("pulse_output = { axis = \"Q\", address = 12 }")
                .unwrap()
                .input
            {
                crate::config::InputSection::Modbus(m) => m,
                _ => unreachable!(),
            },
            &[],
            &["Z".to_string()],
        );
        assert!(r
            .unwrap_err()
            .to_string()
            .contains("input.pulse_output.axis"));
    }

    #[test]
    fn offset_encoding() {
        assert_eq!(encode_offset(-12.34, 0.1).unwrap(), (-123i16) as u16);
        assert_eq!(encode_offset(3276.7, 0.1).unwrap(), 32767);
        assert!(encode_offset(3276.8, 0.1).is_err());
        assert!(encode_offset(f64::NAN, 0.1).is_err());
    }

    proptest! {
        #[test]
        fn decode_never_panics(w in any::<u16>(), signed in any::<bool>(), scale in -1e3f64..1e3) {
            let _ = decode_register(w, &map(signed, scale, 0.0));
        }

        #[test]
        fn encode_round_trips(counts in -32768i32..=32767) {
            let um = f64::from(counts) * 0.1;
            let w = encode_offset(um, 0.1).unwrap();
            prop_assert_eq!(i32::from(w as i16), counts);
        }
    }
}
