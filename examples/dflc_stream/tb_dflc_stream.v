// A user's testbench for the navcores DFLC stream top, in plain Verilog:
// no cocotb, no Python while it runs.  The DUT is the module FuseSoC's
// navcores_dflc generator emitted for dflc_stream_example.core's parameters
// (fll=table1 ip_sz=10 op_sz=14 cpr9_no=2; the module name carries them,
// see its manifest dflc_stream_cpr9_no2_table1_ip_sz10_op_sz14.json).
//
// It streams the samples of golden.hex through the valid/ready streams, with
// gaps on the input and back-pressure on the output (a long stall fills the
// output FIFO, so the core must hold its input), and compares every output
// with the golden model's value.  A failure ends with $fatal (non-zero exit).  golden.hex: python examples/dflc_stream/make_golden.py
`timescale 1ns / 1ps

module tb_dflc_stream;
  localparam N = 24;            // samples in golden.hex
  localparam IP_SZ = 10;
  localparam OP_SZ = 14;
  localparam TIMEOUT = 3000;    // cycles

  reg clk = 1'b0;
  reg rst = 1'b1;               // synchronous, active high
  always #5 clk = ~clk;

  // golden.hex: [9:0] input 0, [19:10] input 1, [33:20] y, [34] zero
  reg [34:0] golden [0:N-1];
  initial $readmemh("golden.hex", golden);

  // The core's streams (a beat moves on a rising edge with valid and ready high).
  reg                  in_valid = 1'b0;
  reg  [2*IP_SZ-1:0]   in_payload = 0;     // input j at bits [j*IP_SZ +: IP_SZ]
  wire                 in_ready;
  wire                 out_valid;
  wire [OP_SZ:0]       out_payload;        // {zero, y}
  reg                  out_ready = 1'b0;

  dflc_stream_cpr9_no2_table1_ip_sz10_op_sz14 dut (
    .clk(clk), .rst(rst),
    .i_stream__valid(in_valid), .i_stream__ready(in_ready), .i_stream__payload(in_payload),
    .o_stream__valid(out_valid), .o_stream__ready(out_ready), .o_stream__payload(out_payload)
  );

  integer cycle = 0;
  integer sent = 0;             // input beats accepted
  integer got = 0;              // output beats taken
  integer errors = 0;
  integer stalled = 0;          // cycles in_valid waited for in_ready
  integer next;

  always @(posedge clk) begin
    cycle <= cycle + 1;
    if (rst) begin
      in_valid <= 1'b0;
      out_ready <= 1'b0;
    end else begin
      // Source: a beat stays valid (payload stable) until it is taken; between
      // beats, a gap every third sample.
      next = sent + (in_valid && in_ready);
      sent <= next;
      if (in_valid && !in_ready) stalled <= stalled + 1;
      if (!in_valid || in_ready) begin
        if (next < N && !(next % 3 == 2 && in_valid)) begin
          in_valid <= 1'b1;
          in_payload <= golden[next][2*IP_SZ-1:0];
        end else begin
          in_valid <= 1'b0;
        end
      end
      // Sink: not ready one cycle in four, and not at all for 80 cycles.
      out_ready <= !(cycle % 4 == 1 || (cycle >= 30 && cycle < 110));
      // Check every output beat, in order.
      if (out_valid && out_ready) begin
        if (out_payload !== golden[got][34:20]) begin
          errors <= errors + 1;
          $display("MISMATCH sample %0d (inputs %0d, %0d): y=%0d zero=%0d, expected y=%0d zero=%0d",
                   got, golden[got][9:0], golden[got][19:10], out_payload[OP_SZ-1:0], out_payload[OP_SZ],
                   golden[got][33:20], golden[got][34]);
        end
        got <= got + 1;
      end
    end
  end

  initial begin
    repeat (3) @(posedge clk);
    rst <= 1'b0;
  end

  // The end: every sample compared, or a timeout.
  always @(posedge clk) begin
    if (got == N) begin
      if (errors == 0 && stalled > 0)
        $display("PASS: %0d samples matched the golden model (%0d cycles, input held %0d cycles by back-pressure)",
                 got, cycle, stalled);
      else
        $fatal(1, "FAIL: %0d of %0d samples differ (input stalled %0d cycles)", errors, got, stalled);
      $finish;
    end
    if (cycle > TIMEOUT) begin
      $fatal(1, "FAIL: timeout after %0d cycles, %0d of %0d samples out", cycle, got, N);
    end
  end
endmodule
