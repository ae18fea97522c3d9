#!/usr/bin/env bash
# DDS-Security material for a maptune deployment (docs/distributed.md, "Security").
#
#   scripts/make-pki.sh DIR                  a new CA, one identity per service role, the signed
#                                            governance and each role's signed permissions
#   scripts/make-pki.sh DIR --add NAME --role ROLE [--expired]
#                                            one more identity (e.g. one per worker host) with
#                                            ROLE's permissions, signed by DIR's CA; --expired
#                                            makes a certificate that ended in 2021 (for tests)
#
# Layout: DIR/ca.pem (identity and permissions CA), DIR/governance.p7s, and per identity
# DIR/NAME/{cert.pem,key.pem,permissions.p7s}. The CA's key stays in DIR/ca/ — keep it off
# the robots. Services use it with `--dds-security DIR` (MAPTUNE_DDS_SECURITY) and, unless
# told `--dds-identity NAME`, the identity named after their role.
#
# Roles (what each may publish; everything else is denied, and no unauthenticated participant
# is admitted): dataset_server — dataset_announcement, file_chunk; sample_db —
# observation_reply, evaluation_task, file_request; worker — task_result, worker_status,
# file_request; optimizer — observation_request, best_so_far, optimizer_status, file_request;
# watch — nothing (reads best_so_far and optimizer_status).
set -euo pipefail

usage() { sed -n '2,20p' "$0" | sed 's/^# \{0,1\}//' >&2; exit 2; }
[ $# -ge 1 ] || usage
dir=$1; shift
add="" role="" expired=0
while [ $# -gt 0 ]; do
  case "$1" in
    --add) add=${2:?}; shift 2 ;;
    --role) role=${2:?}; shift 2 ;;
    --expired) expired=1; shift ;;
    *) usage ;;
  esac
done
command -v openssl >/dev/null || { echo "make-pki: openssl is not installed (apt-get install openssl)" >&2; exit 1; }

t="maptune/v1"
publishes() {
  case "$1" in
    dataset_server) echo "$t/dataset_announcement $t/file_chunk" ;;
    sample_db) echo "$t/observation_reply $t/evaluation_task $t/file_request" ;;
    worker) echo "$t/task_result $t/worker_status $t/file_request" ;;
    optimizer) echo "$t/observation_request $t/best_so_far $t/optimizer_status $t/file_request" ;;
    watch) echo "" ;;
    *) echo "make-pki: unknown role '$1' (dataset_server, sample_db, worker, optimizer, watch)" >&2; exit 2 ;;
  esac
}
subscribes() {
  case "$1" in
    dataset_server) echo "$t/file_request" ;;
    sample_db) echo "$t/observation_request $t/task_result $t/worker_status $t/dataset_announcement $t/file_chunk" ;;
    worker) echo "$t/evaluation_task $t/dataset_announcement $t/file_chunk" ;;
    optimizer) echo "$t/observation_reply $t/worker_status $t/dataset_announcement $t/file_chunk" ;;
    watch) echo "$t/best_so_far $t/optimizer_status" ;;
  esac
}
roles="dataset_server sample_db worker optimizer watch"

# `openssl ca` rather than `x509 -req`: it can set explicit validity dates (--expired).
ca_conf() {
  cat <<EOF
[ca]
default_ca = maptune
[maptune]
dir = $dir/ca
database = \$dir/index.txt
serial = \$dir/serial
new_certs_dir = \$dir/issued
certificate = $dir/ca.pem
private_key = \$dir/key.pem
default_md = sha256
policy = any
unique_subject = no
copy_extensions = none
[any]
countryName = optional
organizationName = optional
commonName = supplied
EOF
}

sign_smime() {  # in out: S/MIME signed by the CA, as DDS-Security's builtin plugins read it
  openssl smime -sign -in "$1" -text -out "$2" -signer "$dir/ca.pem" -inkey "$dir/ca/key.pem" 2>/dev/null
}

topics_xml() {
  local kind=$1; shift
  [ $# -gt 0 ] || return 0
  echo "        <$kind><topics>"
  for topic in "$@"; do echo "          <topic>$topic</topic>"; done
  echo "        </topics></$kind>"
}

new_identity() {  # name role expired
  local name=$1 r=$2 old=$3 out="$dir/$1"
  mkdir -p "$out"
  openssl genpkey -algorithm EC -pkeyopt ec_paramgen_curve:P-256 -out "$out/key.pem" 2>/dev/null
  chmod 600 "$out/key.pem"
  openssl req -new -key "$out/key.pem" -subj "/C=DE/O=maptune/CN=$name" -out "$out/req.pem"
  local dates=(-days 3650)
  if [ "$old" = 1 ]; then dates=(-startdate 20200101000000Z -enddate 20210101000000Z); fi
  openssl ca -batch -notext -config <(ca_conf) "${dates[@]}" -in "$out/req.pem" -out "$out/cert.pem" 2>/dev/null
  rm -f "$out/req.pem"
  local not_before=2020-01-01T00:00:00 not_after=2099-12-31T23:59:59
  # shellcheck disable=SC2046
  {
    cat <<EOF
<?xml version="1.0" encoding="UTF-8"?>
<dds>
  <permissions>
    <grant name="$name">
      <subject_name>CN=$name,O=maptune,C=DE</subject_name>
      <validity><not_before>$not_before</not_before><not_after>$not_after</not_after></validity>
      <allow_rule>
        <domains><id_range><min>0</min><max>232</max></id_range></domains>
EOF
    topics_xml publish $(publishes "$r")
    topics_xml subscribe $(subscribes "$r")
    cat <<EOF
      </allow_rule>
      <default>DENY</default>
    </grant>
  </permissions>
</dds>
EOF
  } >"$out/permissions.xml"
  sign_smime "$out/permissions.xml" "$out/permissions.p7s"
  echo "$r" >"$out/role"
}

if [ -n "$add" ]; then
  [ -n "$role" ] || { echo "make-pki: --add needs --role" >&2; exit 2; }
  [ -f "$dir/ca/key.pem" ] || { echo "make-pki: $dir has no CA (run scripts/make-pki.sh $dir first)" >&2; exit 1; }
  [[ "$add" =~ ^[A-Za-z0-9_.-]+$ ]] || { echo "make-pki: identity name '$add': letters, digits, _ . - only" >&2; exit 2; }
  publishes "$role" >/dev/null
  [ ! -e "$dir/$add" ] || { echo "make-pki: $dir/$add exists" >&2; exit 1; }
  new_identity "$add" "$role" "$expired"
  echo "make-pki: identity $add ($role) in $dir/$add"
  exit 0
fi

[ ! -e "$dir/ca.pem" ] || { echo "make-pki: $dir already holds a PKI (ca.pem); use another directory" >&2; exit 1; }
mkdir -p "$dir/ca/issued"
chmod 700 "$dir/ca"
: >"$dir/ca/index.txt"
echo 1000 >"$dir/ca/serial"
openssl genpkey -algorithm EC -pkeyopt ec_paramgen_curve:P-256 -out "$dir/ca/key.pem" 2>/dev/null
openssl req -x509 -new -key "$dir/ca/key.pem" -sha256 -days 3650 \
  -subj "/C=DE/O=maptune/CN=maptune CA $(date -u +%Y%m%dT%H%M%S) $RANDOM" -out "$dir/ca.pem"

# Governance: authenticated participants only, join and topic access checked against the
# permissions, discovery, liveliness and data encrypted, every RTPS message signed.
cat >"$dir/governance.xml" <<EOF
<?xml version="1.0" encoding="UTF-8"?>
<dds>
  <domain_access_rules>
    <domain_rule>
      <domains><id_range><min>0</min><max>232</max></id_range></domains>
      <allow_unauthenticated_participants>false</allow_unauthenticated_participants>
      <enable_join_access_control>true</enable_join_access_control>
      <discovery_protection_kind>ENCRYPT</discovery_protection_kind>
      <liveliness_protection_kind>ENCRYPT</liveliness_protection_kind>
      <rtps_protection_kind>SIGN</rtps_protection_kind>
      <topic_access_rules>
        <topic_rule>
          <topic_expression>*</topic_expression>
          <enable_discovery_protection>true</enable_discovery_protection>
          <enable_liveliness_protection>true</enable_liveliness_protection>
          <enable_read_access_control>true</enable_read_access_control>
          <enable_write_access_control>true</enable_write_access_control>
          <metadata_protection_kind>ENCRYPT</metadata_protection_kind>
          <data_protection_kind>ENCRYPT</data_protection_kind>
        </topic_rule>
      </topic_access_rules>
    </domain_rule>
  </domain_access_rules>
</dds>
EOF
sign_smime "$dir/governance.xml" "$dir/governance.p7s"
for r in $roles; do new_identity "$r" "$r" 0; done
echo "make-pki: CA, governance and identities ($roles) in $dir"
