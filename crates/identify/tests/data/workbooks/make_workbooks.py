#!/usr/bin/env python3
"""Writes the workbook fixtures of the spreadsheet tests with an independent writer (openpyxl;
pandas with odfpy for the OpenDocument file; xlwt for the Excel 97-2003 .xls files), and the CSV logs holding the same values.

    pip install openpyxl pandas odfpy xlwt
    python3 crates/identify/tests/data/workbooks/make_workbooks.py

Run from anywhere; writes beside this script and into crates/cli/tests/fixtures/. The Rust
tests read the files only (no Python at test time).
"""
import datetime as dt
import os

import openpyxl
import pandas as pd
from openpyxl.utils.datetime import CALENDAR_MAC_1904

HERE = os.path.dirname(os.path.abspath(__file__))
CLI = os.path.normpath(os.path.join(HERE, "..", "..", "..", "..", "cli", "tests", "fixtures"))


def dates():
    """8 rows 37.25 s apart across midnight into a leap day (2024-02-29)."""
    t0 = dt.datetime(2024, 2, 28, 23, 58, 0)
    rows = []
    for k in range(8):
        a = 20.0 + 0.5 * k
        b = 21.0 - 0.25 * k
        c = 19.0 + 0.125 * k * k
        rows.append((t0 + dt.timedelta(milliseconds=37250 * k), a, b, c, 3.0 * a - 2.0 * b + 0.5 * c))
    return rows


def write_dates(path, epoch_1904):
    wb = openpyxl.Workbook()
    if epoch_1904:
        wb.epoch = CALENDAR_MAC_1904
    ws = wb.active
    ws.title = "log"
    ws.append(["stamp", "a_c", "b_c", "c_c", "d_um"])
    for r in dates():
        ws.append(list(r))
        ws.cell(row=ws.max_row, column=1).number_format = "yyyy-mm-dd hh:mm:ss.000"
    wb.save(path)


def cells():
    """Sheet 'day 3': time_s, a_c, b_c, d_um, 20 rows; B10 #DIV/0!, C17 'oops', D12 empty,
    C5 the text '21.5' (a number written as text)."""
    wb = openpyxl.Workbook()
    ws = wb.active
    ws.title = "day 3"
    ws.append(["time_s", "a_c", "b_c", "d_um"])
    for k in range(20):
        a = 20.0 + 0.1 * k
        b = 21.0 + 0.05 * k * k
        ws.append([60.0 * k, a, b, 2.0 * a - b])
    ws["B10"] = "#DIV/0!"  # openpyxl stores a known error code as an error cell
    ws["C17"] = "oops"
    ws["D12"] = None
    ws["C5"] = "21.5"
    wb.save(os.path.join(HERE, "cells.xlsx"))


def day(d, n):
    """Day d (1-based) of a test: n rows a minute apart, three temperatures, one drift."""
    rows = []
    for k in range(n):
        t1 = 20.0 + 0.02 * k + 0.5 * d
        t2 = 22.0 + 0.001 * k * k - 0.25 * d
        t3 = 18.0 + 0.03 * ((k * 7 + d) % 11)
        drift = 2.0 * t1 - 1.5 * t2 + 0.75 * t3 + 0.01 * ((k * 5 + 3 * d) % 7)
        rows.append(tuple(g16(v) for v in (60.0 * k, t1, t2, t3, drift)))
    return rows


def g16(v):
    """v as openpyxl writes it into a workbook (16 significant digits, '%.16g'), so that the
    CSV logs hold exactly the values the workbooks hold."""
    return float("%.16g" % v)


def write_csv(path, header, rows):
    with open(path, "w", newline="\n") as f:
        if header:
            f.write(",".join(header) + "\n")
        for r in rows:
            f.write(",".join(repr(v) for v in r) + "\n")


def days():
    header = ["time_s", "t1_c", "t2_c", "t3_c", "d_um"]
    wb = openpyxl.Workbook()
    wb.remove(wb.active)
    notes = wb.create_sheet("notes")
    notes.append(["machine", "test rig 2"])
    notes.append(["operator", "night shift"])
    for d in (1, 2, 3):
        ws = wb.create_sheet(f"day {d}")
        ws.append(header)
        for r in day(d, 40):
            ws.append(list(r))
        write_csv(os.path.join(CLI, f"day {d}.csv"), header, day(d, 40))
    wb.save(os.path.join(CLI, "days.xlsx"))
    # The same three days with every sheet a run (no notes sheet), and header-less.
    wb = openpyxl.Workbook()
    wb.remove(wb.active)
    for d in (1, 2, 3):
        ws = wb.create_sheet(f"day {d}")
        for r in day(d, 40):
            ws.append(list(r))
    wb.save(os.path.join(CLI, "days_noheader.xlsx"))
    write_csv(os.path.join(CLI, "day 1 noheader.csv"), None, day(1, 40))
    # The temperatures in one workbook, the drift in another (--target-data).
    temps, drift = openpyxl.Workbook(), openpyxl.Workbook()
    temps.remove(temps.active)
    drift.remove(drift.active)
    for d in (1, 2, 3):
        ws, wd = temps.create_sheet(f"day {d}"), drift.create_sheet(f"day {d}")
        ws.append(header[:4])
        wd.append(header[4:])
        for r in day(d, 40):
            ws.append(list(r[:4]))
            wd.append(list(r[4:]))
    temps.save(os.path.join(CLI, "days_temps.xlsx"))
    drift.save(os.path.join(CLI, "days_drift.xlsx"))
    # OpenDocument: day 1 with its header.
    pd.DataFrame(day(1, 40), columns=header).to_excel(
        os.path.join(CLI, "day 1.ods"), sheet_name="day 1", index=False, engine="odf"
    )


def write_xls():
    """The legacy binary format (BIFF, .xls): day 1 with its header, and the dates in the
    1904 epoch."""
    import xlwt

    wb = xlwt.Workbook()
    ws = wb.add_sheet("day 1")
    for c, h in enumerate(["time_s", "t1_c", "t2_c", "t3_c", "d_um"]):
        ws.write(0, c, h)
    for r, row in enumerate(day(1, 40)):
        for c, v in enumerate(row):
            ws.write(r + 1, c, v)
    wb.save(os.path.join(CLI, "day 1.xls"))
    wb = xlwt.Workbook()
    wb.dates_1904 = True
    ws = wb.add_sheet("log")
    stamp = xlwt.easyxf(num_format_str="yyyy-mm-dd hh:mm:ss.000")
    for c, h in enumerate(["stamp", "a_c", "b_c", "c_c", "d_um"]):
        ws.write(0, c, h)
    for r, row in enumerate(dates()):
        # xlwt drops the milliseconds of a datetime: the 1904 serial date written as a
        # number in the date format (days since 1904-01-01 00:00).
        serial = (row[0] - dt.datetime(1904, 1, 1)).total_seconds() / 86400.0
        ws.write(r + 1, 0, serial, stamp)
        for c, v in enumerate(row[1:]):
            ws.write(r + 1, c + 1, v)
    wb.save(os.path.join(HERE, "dates_1904.xls"))


if __name__ == "__main__":
    os.makedirs(CLI, exist_ok=True)
    write_dates(os.path.join(HERE, "dates.xlsx"), False)
    write_dates(os.path.join(HERE, "dates_1904.xlsx"), True)
    with open(os.path.join(HERE, "dates.csv"), "w", newline="\n") as f:
        f.write("stamp,a_c,b_c,c_c,d_um\n")
        for r in dates():
            f.write(r[0].strftime("%Y-%m-%d %H:%M:%S.%f")[:-3] + "," + ",".join(repr(v) for v in r[1:]) + "\n")
    cells()
    days()
    write_xls()
