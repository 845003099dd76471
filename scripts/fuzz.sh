#!/usr/bin/env bash
# Builds every libFuzzer target (tests/CMakeLists.txt: volume headers and payloads, DICOM,
# traces, materials and incision files, device bridge packets, sweep manifests) with clang 14 under
# ASan+UBSan, and runs each for a bounded time on a corpus seeded from real files: the bundled volumes, traces and TOML
# files, pydicom's DICOM test files, mricron's NIfTI templates, and small files of every
# volume format. A crash, a sanitizer report, an abort from a target's own checks (a read
# whose sizes do not match, an error that is not one line naming the file), an input that
# runs past -timeout or allocates past -rss_limit_mb fails the run; the input that did it is
# kept in build-fuzz/crashes/ (replay it: build-fuzz/tests/NAME FILE).
# Usage: scripts/fuzz.sh [SECONDS_PER_TARGET]   (default 30; CI runs the default)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
seconds=${1:-30}
# clang and its libFuzzer runtime: only this script needs them (the project builds with GCC).
bash "$root/scripts/setup.sh" clang-14 libclang-rt-14-dev

build_dir="$root/build-fuzz"
targets=(volume_fuzz dicom_fuzz trace_fuzz materials_fuzz incision_fuzz bridge_fuzz
  pointer_script_fuzz sweep_manifest_fuzz)
mkdir -p "$build_dir"
if ! bash "$root/scripts/build.sh" --target "${targets[*]}" "$build_dir" \
  -DCMAKE_C_COMPILER=clang-14 -DCMAKE_CXX_COMPILER=clang++-14 -DHAPVOX_SANITIZE=address \
  >"$build_dir/build.log" 2>&1; then
  tail -n 60 "$build_dir/build.log"
  echo "fuzz.sh: build failed (full log: $build_dir/build.log)" >&2
  exit 1
fi

# Seeds. A target's first byte (two for DICOM) picks the parser or layout: see each target's
# header comment. Seeds are prefixed accordingly.
seeds="$build_dir/seeds"
rm -rf "$seeds"
mkdir -p "$seeds"/{volume_fuzz,dicom_fuzz,trace_fuzz,materials_fuzz,incision_fuzz,bridge_fuzz,pointer_script_fuzz,sweep_manifest_fuzz}
prefixed() {  # prefixed PREFIX_PRINTF_FORMAT FILE OUT
  { printf "$1"; cat "$2"; } >"$3"
}
# Volumes: 0 NRRD, 1 MetaImage, 2 NIfTI, 3 gzip NIfTI, 4 raw (its layout's line, then the file).
for f in "$root"/data/*.nrrd; do prefixed '\000' "$f" "$seeds/volume_fuzz/$(basename "$f")"; done
for f in /usr/share/mricron/templates/JHU-WhiteMatter-labels-2mm.nii.gz \
  /usr/share/mricron/templates/AICHAmc.nii.gz; do
  [ -f "$f" ] && prefixed '\003' "$f" "$seeds/volume_fuzz/$(basename "$f")"
done
/usr/bin/python3 - "$seeds/volume_fuzz" <<'EOF'
# Small whole files: a turned, scaled NIfTI from nibabel (plain and gzip), MetaImage raw and
# zlib, a raw file with its layout, NRRD raw with space directions.
import gzip, sys, zlib
import nibabel, numpy
out = sys.argv[1]
data = numpy.arange(4 * 3 * 2, dtype=numpy.int16).reshape(4, 3, 2)
affine = numpy.array([[0, -2, 0, 10], [1, 0, 0, -5], [0, 0, 3, 7], [0, 0, 0, 1]], float)
image = nibabel.Nifti1Image(data, affine)
image.header.set_sform(affine, code=1)
image.header.set_qform(affine, code=1)
raw_nifti = image.to_bytes()
open(f"{out}/small.nii", "wb").write(b"\x02" + raw_nifti)
open(f"{out}/small.nii.gz", "wb").write(b"\x03" + gzip.compress(raw_nifti))
payload = bytes(range(24))
header = ("ObjectType = Image\nNDims = 3\nDimSize = 4 3 2\nElementSpacing = 1 2 3\n"
          "TransformMatrix = 0 1 0 -1 0 0 0 0 1\nOffset = 1 2 3\nAnatomicalOrientation = RAI\n"
          "ElementType = MET_UCHAR\n")
open(f"{out}/small.mha", "wb").write(
    b"\x01" + (header + "ElementDataFile = LOCAL\n").encode() + payload)
packed = zlib.compress(payload)
open(f"{out}/small_zlib.mha", "wb").write(
    b"\x01" + (header + f"CompressedData = True\nCompressedDataSize = {len(packed)}\n"
               "ElementDataFile = LOCAL\n").encode() + packed)
open(f"{out}/small.raw", "wb").write(
    b"\x04" + b"dims=4x3x2,type=uint8,endian=big,spacing_mm=1x2x3,header_bytes=2\n" + b"HD" + payload)
open(f"{out}/small.nrrd", "wb").write(
    b"\x00" + b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 4 3 2\nspace: left-posterior-superior\n"
    b"space directions: (0,1,0) (-2,0,0) (0,0,3)\nspace origin: (1,2,3)\nencoding: raw\n\n"
    + payload)
EOF
# DICOM: layout 0 (one file) for each, layout 1 (a two-file folder, split at 50 %) for CT_small.
pydicom_files=/usr/lib/python3/dist-packages/pydicom/data/test_files
for f in CT_small.dcm MR_small.dcm image_dfl.dcm MR_small_jpeg_ls_lossless.dcm JPEG2000.dcm \
  ExplVR_BigEndNoMeta.dcm rtdose_1frame.dcm; do
  prefixed '\000\000' "$pydicom_files/$f" "$seeds/dicom_fuzz/$f"
done
prefixed '\001\200' "$pydicom_files/CT_small.dcm" "$seeds/dicom_fuzz/series_CT_small"
# Traces: 0 CSV with orientation columns (the bundled traces with an identity quaternion added),
# 1 H3D DeviceLog.
for f in engine_grab.csv engine_press_irregular.csv; do
  { printf '\000'; awk -F, 'NR == 1 { print $0 ",qw,qx,qy,qz"; next } { print $0 ",1,0,0,0" }' \
    "$root/traces/$f"; } >"$seeds/trace_fuzz/$f"
done
printf '\001TIME POSITION ORIENTATION BUTTONS\n0 0.01 0.02 0.03 0 0 1 0 0\n0.001 0.011 0.02 0.03 0 0 1 0.1 1\n0.002 0.012 0.021 0.03 1 0 0 0.2 1\n' \
  >"$seeds/trace_fuzz/devicelog.txt"
printf '\001TIME RAW_POSITION RAW_ORIENTATION\n0 0.1 0 0 0 0 1 0\n0.5 0.2 0 0 0 0 1 0.5\n' \
  >"$seeds/trace_fuzz/devicelog_raw.txt"
for f in "$root"/data/*.toml; do
  case "$f" in
    *incision*) cp "$f" "$seeds/incision_fuzz/" ;;
    *) cp "$f" "$seeds/materials_fuzz/" ;;
  esac
done

# Device bridge packets (docs/formats.md): 0 a position packet, 1 a force packet; 2 and 3 the
# same keyed, their HMAC-SHA256 tag under bridge_packet_fuzz.cc's key appended.
python3 - "$seeds/bridge_fuzz" <<'PY'
import hashlib, hmac, struct, sys
head = lambda kind, seq: b"HVXB" + struct.pack("<HHIQ", 1, kind, seq, 123456789)
position = head(1, 7) + struct.pack("<3d4dIII", 10.0, -20.0, 30.5, 1.0, 0.0, 0.0, 0.0, 3, 1, 150000)
force = head(2, 8) + struct.pack("<IQQ3dI", 7, 123456789, 1000, 0.5, 0.0, -1.0, 1)
tag = lambda packet: hmac.new(b"hapvox bridge fuzz key", packet, hashlib.sha256).digest()
open(sys.argv[1] + "/position", "wb").write(b"\0" + position)
open(sys.argv[1] + "/force", "wb").write(b"\1" + force)
open(sys.argv[1] + "/position_keyed", "wb").write(b"\2" + position + tag(position))
open(sys.argv[1] + "/force_keyed", "wb").write(b"\3" + force + tag(force))
PY

# Sculpting window scripts (haptics/pointer_script.h): the bundled one.
cp "$root"/traces/*.script "$seeds/pointer_script_fuzz/"
cp "$root"/data/sweep_example.toml "$seeds/sweep_manifest_fuzz/"

export ASAN_OPTIONS=${ASAN_OPTIONS:-"abort_on_error=1"}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-"print_stacktrace=1:halt_on_error=1"}
mkdir -p "$build_dir/crashes"
status=0
for t in "${targets[@]}"; do
  corpus="$build_dir/corpus/$t"
  mkdir -p "$corpus"
  log="$build_dir/$t.log"
  # Inputs up to 1 MiB: the seeds hold whole real files (a gzip NIfTI must be whole to read).
  if "$build_dir/tests/$t" -max_total_time="$seconds" -timeout=20 -rss_limit_mb=2560 \
    -max_len=1048576 -print_final_stats=1 -artifact_prefix="$build_dir/crashes/$t-" \
    "$corpus" "$seeds/$t" >"$log" 2>&1; then
    runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log")
    echo "fuzz: $t: no crash in ${seconds} s, ${runs:-?} inputs run, corpus $(ls "$corpus" | wc -l) files"
  else
    tail -n 40 "$log"
    echo "fuzz: $t failed (log: $log; the input: $build_dir/crashes/$t-*)" >&2
    status=1
  fi
done
exit $status
